"""The realism report's text: ``report.md`` from the result dict of
:func:`sdcomp.report.realism.report.realism_report`."""

from __future__ import annotations

from .analysis import UNITS
from .patches import METRICS
from .targets import MEDIAN_TARGETS, REAL_REFERENCE, SDCOMP_ISSUE, verdict


def row_text(s: dict | None) -> str:
    """"median [p10, p90]" of a summary row (:func:`.patches.summarise`); "n/a" if empty."""
    if not s or not s.get("n"):
        return "n/a"
    if "p10" in s and "p90" in s:
        return f"{s['median']:.3g} [{s['p10']:.3g}, {s['p90']:.3g}]"
    return f"{s['median']:.3g}"


def _ref(d: dict) -> str:
    if "p10" in d:
        return f"{d['median']:.3g} [{d['p10']:.3g}, {d['p90']:.3g}]"
    return f"{d['median']:.3g}"


def _cv_text(c: dict | None, name: str) -> list[str]:
    if c is None:
        return []
    if "error" in c:
        return [f"- {name}: not run ({c['error']})"]
    lo, hi = c["ci95_binomial"]
    ilo, ihi = c["ci95_images"]
    lines = [f"- {name}: accuracy **{c['accuracy']:.3f}** ({c['correct']}/{c['n_test']} "
             f"patches; 95 % binomial CI [{lo:.3f}, {hi:.3f}], image-bootstrap CI "
             f"[{ilo:.3f}, {ihi:.3f}]); {c['folds']} folds split by image, "
             f"{c['patches_per_class'][0]} patches per class (balanced), images "
             f"{c['images_per_class'][0]} generated / {c['images_per_class'][1]} real; "
             f"fold accuracies {', '.join(f'{a:.2f}' for a in c['fold_accuracy'])}"]
    if ihi < 0.5:
        lines.append("  - below chance: the two sets probably share images or near-duplicates "
                     "(a copy in the training folds teaches the opposite label), or have too "
                     "few images")
    if c.get("top_features"):
        feats = ", ".join(f"{n} ({'+' if w > 0 else '-'}{abs(w):.2f})"
                          for n, w in c["top_features"])
        lines.append(f"  - most discriminative (standardised weight; + = higher in real): "
                     f"{feats}")
    return lines


def render_markdown(r: dict) -> str:
    """The report.md text of a :func:`realism_report` result."""
    g, rl = r["generated"], r["real"]
    gs, rs = r["summary"]["generated"], r["summary"]["real"]
    lines = ["# Realism report", "",
             f"Generated: `{g['folder']}`: {g['images_read']} images, {g['empty_water_patches']}"
             f" empty-water patches of {g['patches']} ({g['ms_per_image']} ms per image)."]
    if rl:
        lines.append(f"Real: `{rl['folder']}`: {rl['images_read']} frames, "
                     f"{rl['empty_water_patches']} empty-water patches of {rl['patches']} "
                     f"({rl['ms_per_image']} ms per frame).")
    else:
        lines.append("No real frames: statistics against the targets only.")
    lines += ["", "Per-patch statistics of empty-water 64x64 patches: median [p10, p90] "
              "(definitions: docs/realism.md).", ""]
    head = "| metric | generated |" + (" real (measured) |" if rs else "")
    head += " real (reference) | flat colours (reference) | target for the median |"
    lines += [head, "|" + "---|" * (head.count("|") - 1)]
    for m in METRICS:
        tgt = MEDIAN_TARGETS.get(m)
        t_text = f"{tgt[0]:g}-{tgt[1]:g}" if tgt else "-"
        if tgt:
            ok = tgt[0] <= gs[m]["median"] <= tgt[1]
            t_text += f" **{verdict(ok)}**"
        row = f"| {m} ({UNITS[m]}) | {row_text(gs[m])} |"
        if rs:
            row += f" {row_text(rs[m])} |"
        row += f" {_ref(REAL_REFERENCE[m])} | {_ref(SDCOMP_ISSUE[m])} | {t_text} |"
        lines.append(row)
    lines += ["", "## Targets (generated set)", "", "| target | value | verdict |",
              "|---|---|---|"]
    for t in r["targets"]:
        v = t["value"]
        lines.append(f"| {t['target']} | {'n/a' if v is None else f'{v:.4g}'} | "
                     f"**{verdict(t['ok'])}** |")
    n_pass = sum(1 for t in r["targets"] if t["ok"] is True)
    n_judged = sum(1 for t in r["targets"] if t["ok"] is not None)
    lines += ["", f"{n_pass} of {n_judged} judged targets pass.", ""]
    lines += ["## Real vs synthetic classifier", ""]
    if r["classifier"] is None:
        lines.append("Not run: no real frames.")
    else:
        lines.append("Realism number: cross-validated accuracy of telling a real empty-water "
                     "patch from a generated one (0.5 = indistinguishable, 1.0 = always "
                     "told apart).")
        lines += _cv_text(r["classifier"], "logistic regression on 45 patch features")
        lines += _cv_text(r.get("cnn"), "tiny CNN on the raw patches")
    lines += ["", "## Figures", "",
              "![luminance power spectra](spectrum.png)", "",
              "![per-patch statistics](histograms.png)", "",
              f"![crops]({'crops.png'})", "", f"Crops: {r['crops']['note']}.", "",
              "## How the sets were read", ""]
    for info in (g, rl):
        if not info:
            continue
        gsd = info["gsd_m_per_px"]
        gtext = (f"GSD known for {gsd['known']} images: {gsd['min']:.4f}-{gsd['max']:.4f} m/px "
                 f"(median {gsd['median']:.4f})" if gsd.get("known") else "GSD unknown")
        how = ", ".join(f"{k}: {v}" for k, v in info["valid_pixels"].items())
        lines.append(f"- {info['kind']}: {gtext}; valid pixels: {how or 'all'}"
                     + (f"; {info['rescaled_to_match_gsd']} frames resampled to the "
                        f"generated median GSD" if info["rescaled_to_match_gsd"] else "")
                     + (f"; {info['unreadable']} unreadable images skipped"
                        if info["unreadable"] else ""))
        for note in info["notes"]:
            lines.append(f"  - {note}")
    s = r["settings"]
    lines += ["", f"Settings: max images {s['max_images']}, seed {s['seed']}, "
              f"exclude clutter {s['exclude_clutter']}, match GSD {s['match_gsd']}; "
              f"{r['seconds']} s in all.", ""]
    return "\n".join(lines)
