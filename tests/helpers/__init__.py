"""What the tests share and are not tests: agreement checks, test systems, probe studies and scripts, paths."""
