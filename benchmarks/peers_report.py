"""Matched-error interpolation, the markdown tables and the summary of benchmarks/peers.py."""

from __future__ import annotations

import math


def _series(rows) -> dict:
    """{(engine, method): rows sorted by decreasing tolerance}."""
    out = {}
    for row in rows:
        out.setdefault((row["engine"], row["method"]), []).append(row)
    return {key: sorted(value, key=lambda r: -r["tol"]) for key, value in out.items()}


def at_error(points, target: float) -> dict | None:
    """Time at median error ``target`` by log-log interpolation between the first two consecutive
    tolerances (loosest first) whose median errors bracket it; None where none do."""
    for a, b in zip(points, points[1:]):
        e1, e2 = a["err_median_s"], b["err_median_s"]
        if e1 >= target >= e2 and e1 > e2 > 0:
            w = (math.log(target) - math.log(e1)) / (math.log(e2) - math.log(e1))

            def interp(key, a=a, b=b, w=w):
                return math.exp(math.log(a[key]) + w * (math.log(b[key]) - math.log(a[key])))

            return {"wall_s": interp("wall_best_s"), "cpu_s": interp("cpu_best_s"), "tol": interp("tol"),
                    "between_tols": [a["tol"], b["tol"]], "between_errors": [e1, e2]}
    return None


def matched(rows, targets) -> dict:
    """Per target error: each engine's interpolated time, rimroll's best method, and the time ratios
    rimroll / heyoka (> 1: heyoka is faster)."""
    out = {}
    for target in targets:
        entry = {}
        for (engine, method), points in _series(rows).items():
            entry[f"{engine}_{method}"] = at_error(points, target)
        hy = entry.get("heyoka_taylor")
        ours = {k: v for k, v in entry.items() if k.startswith("rimroll_") and v}
        if hy and ours:
            best = min(ours, key=lambda k: ours[k]["wall_s"])
            entry["rimroll_best"] = best
            entry["ratio_rimroll_over_heyoka_wall"] = {k: v["wall_s"] / hy["wall_s"] for k, v in ours.items()}
            entry["ratio_rimroll_over_heyoka_cpu"] = {k: v["cpu_s"] / hy["cpu_s"] for k, v in ours.items()}
        out[f"{target:g}"] = entry
    return out


def _f(value, fmt=".3f") -> str:
    return "n/a" if value is None else format(value, fmt)


def _matched_table(result) -> list[str]:
    targets = list(result["matched"])
    names = sorted({k for entry in result["matched"].values() for k, v in entry.items() if isinstance(v, dict)
                    and "wall_s" in v}, key=lambda k: (not k.startswith("heyoka"), k))
    head = " | ".join(f"wall at {t} [s] | CPU at {t} [s] | x heyoka at {t}" for t in targets)
    lines = [f"| engine | {head} |", "|---" * (1 + 3 * len(targets)) + "|"]
    for name in names:
        cells = []
        for t in targets:
            v = result["matched"][t].get(name)
            ratio = result["matched"][t].get("ratio_rimroll_over_heyoka_wall", {}).get(name)
            cells += [_f(v and v["wall_s"]), _f(v and v["cpu_s"]), "1" if name == "heyoka_taylor" and v
                      else _f(ratio, ".2f")]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def _rows_table(rows) -> list[str]:
    lines = ["| engine | method | tol | order | wall best [s] | wall median [s] | CPU best [s] | median err [s] | "
             "max err [s] | steps | outcome diffs (86,400) | wrong in sample |", "|---" * 12 + "|"]
    for r in rows:
        steps = r.get("lane_steps", r.get("steps"))
        cells = [r["engine"], r["method"], f"{r['tol']:g}", r.get("order", ""), f"{r['wall_best_s']:.3f}",
                 f"{r['wall_median_s']:.3f}", f"{r['cpu_best_s']:.3f}", f"{r['err_median_s']:.2e}",
                 f"{r['err_max_s']:.2e}", f"{steps:,}", r["outcome_differs_from_reference"],
                 r["outcome_wrong_in_sample"]]
        lines.append("| " + " | ".join(map(str, cells)) + " |")
    return lines


def _cold_table(cold) -> list[str]:
    lines = ["| engine | setting | import CPU [s] | compile CPU [s] | compile wall [s] |", "|---" * 5 + "|"]
    for c in cold:
        if "error" in c:
            lines.append(f"| {c['engine']} | {c['setting']} | failed: {c['error']} | | |")
        else:
            lines.append(f"| {c['engine']} | {c['setting']} | {c['import_cpu_s']:.2f} | {c['compile_cpu_s']:.2f} | "
                         f"{c['compile_wall_s']:.2f} |")
    return lines


def markdown(result) -> str:
    meta = result["meta"]
    check = meta.get("model_check")  # absent when heyoka is not installed
    worst = max(v for k, v in check.items() if k.startswith("rel_diff")) if check else None
    lines = [
        "# Peer benchmark: the Fig. 11 rolling section, heyoka and rimroll", "",
        f"{meta['section']}. {meta['cores']} cores, {meta['rounds']} alternating rounds (best counts); "
        "versions: " + ", ".join(f"{k} {v}" for k, v in meta["versions"].items()) + ".", "",
        f"Load before: `{meta['load_before']['uptime']}`; after: `{meta['load_after']['uptime']}`.", "",
        f"Errors: |t_end - truth| over {meta['truth']['n']} states that fall after integration "
        f"({meta['truth']['fall_in']} in, {meta['truth']['fall_out']} out); truth: {meta['truth']['method']}, "
        f"rtol {meta['truth']['rtol']:g}, atol {meta['truth']['atol']:g}. Outcome diffs: cells whose outcome "
        "differs from rimroll dop853 at rtol 1e-12 (all 86,400).", "",
        (f"heyoka model check: rates and F2 against rimroll's at {check['random_states']} random states, largest "
         f"relative difference {worst:.1e}; rules identical." if check else "heyoka is not installed: no heyoka rows."),
        "",
        "## Time at matched median error", "",
        "Log-log interpolation between the two tolerances whose median errors bracket the target; "
        "x heyoka = rimroll's time over heyoka's (> 1: heyoka is faster).", "",
        *_matched_table(result), "",
        "## Every configuration", "",
        "heyoka: lane-steps; rimroll: attempted steps. atol = rtol / 100 for rimroll.", "",
        *_rows_table(result["rows"]), "",
    ]
    if result["cold_compile"]:
        lines += ["## Cold compile (fresh process, empty cache)", "", *_cold_table(result["cold_compile"]), ""]
    return "\n".join(lines)


def summary(result) -> str:
    """One paragraph: times at matched error, the ratios, cold compile, outcome agreement, load."""
    meta, parts = result["meta"], []
    for target, entry in result["matched"].items():
        hy, best = entry.get("heyoka_taylor"), entry.get("rimroll_best")
        if not hy or not best:
            parts.append(f"at median error {target} not every engine is bracketed (widen the tolerances)")
            continue
        others = ", ".join(f"{k.removeprefix('rimroll_')} {v['wall_s']:.3f} s"
                           for k, v in entry.items() if k.startswith("rimroll_") and isinstance(v, dict))
        ratio = entry["ratio_rimroll_over_heyoka_wall"][best]
        parts.append(f"at median t_end error {target} heyoka takes {hy['wall_s']:.3f} s and rimroll {others} "
                     f"(best {best.removeprefix('rimroll_')}: {ratio:.2f}x heyoka's time)")
    cold = result["cold_compile"]
    cold_text = ""
    if cold:
        hy = [c["compile_cpu_s"] for c in cold if c["engine"] == "heyoka" and "error" not in c]
        rr = {c["setting"]: c["compile_cpu_s"] for c in cold if c["engine"] == "rimroll" and "error" not in c}
        hy_text = f"heyoka {min(hy):.2f}-{max(hy):.2f} s (by tolerance), " if hy else ""
        cold_text = (" Cold compile, CPU in a fresh process with an empty cache: " + hy_text + "rimroll "
                     + ", ".join(f"{k} {v:.1f} s" for k, v in rr.items()) + ".")
    exact = [r for r in result["rows"] if r["method"] == "reduced"]
    if exact:  # one row, no tolerance series: its time and error as measured
        r = exact[0]
        parts.append(f"the exact reduced solver takes {r['wall_best_s']:.3f} s at median t_end error "
                     f"{r['err_median_s']:.1e} s (max {r['err_max_s']:.1e} s)")
    diffs = {f"{r['engine']} {r['method']} {r['tol']:g}": r["outcome_differs_from_reference"] for r in result["rows"]}
    bad = {k: v for k, v in diffs.items() if v}
    agree = (f" All {len(diffs)} configurations give rimroll dop853 1e-12's outcome on all 86,400 cells." if not bad
             else f" Outcomes differing from rimroll dop853 1e-12: {bad}.")
    return (f"Fig. 11 rolling section ({meta['cores']} cores, best of {meta['rounds']} alternating rounds, "
            f"load average {meta['load_before']['loadavg'][0]} before and {meta['load_after']['loadavg'][0]} after): "
            + "; ".join(parts) + "." + cold_text + agree)
