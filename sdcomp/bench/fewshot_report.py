"""The ``bench fewshot`` report: ``report.md`` (AP50, AP and AR100 by K and arm, the mean
and spread over seeds, and what the synthetic data is worth at each K) and ``fewshot.png``
(AP50 against K for each arm)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..util.files import atomic_write_bytes

ARM_NAMES = {"real": "real only", "synthetic": "synthetic only",
             "finetune": "synthetic, fine-tuned on K", "mixed": "synthetic + K mixed"}


def table(result: dict, metric: str = "AP50") -> dict[str, dict[int, list[float]]]:
    """{arm: {K: [metric of each seed]}} from ``fewshot.json``'s cells; the synthetic arm
    (trained once per seed) stands at every K, and at K = 0 so do the arms built on it."""
    out: dict[str, dict[int, list[float]]] = {}
    syn = {c["seed"]: c["metrics"][metric] for c in result["cells"] if c["arm"] == "synthetic"}
    for c in result["cells"]:
        if c["arm"] != "synthetic":
            out.setdefault(c["arm"], {}).setdefault(c["k"], []).append(c["metrics"][metric])
    for k in result["ks"]:
        out.setdefault("synthetic", {})[k] = list(syn.values())
        if k == 0:
            for arm in ("finetune", "mixed"):
                out.setdefault(arm, {})[0] = list(syn.values())
    return out


def _cell(values: list[float] | None) -> str:
    if not values or min(values) < 0:
        return "-"
    v = 100 * np.asarray(values)
    return f"{v.mean():.1f} ± {v.std():.1f}" if len(v) > 1 else f"{v[0]:.1f}"


def render_markdown(result: dict) -> str:
    """report.md of ``fewshot.json``'s contents."""
    lines = ["# bench fewshot", "",
             f"Real frames {result['real']} ({result['labels']}): {result['pool']} in the "
             f"training pool, {result['test']} held out for testing ({result['test_boxes']} "
             f"boxes; split by source photo or video). Generated: "
             f"{', '.join(result['train'])}. Seeds {result['seeds']}; mixed arm: "
             f"{100 * result['ratio']:.0f} % real images. Values x 100, mean ± std over "
             f"seeds.", ""]
    arms = ["real", "synthetic", "finetune", "mixed"]
    for metric in ("AP50", "AP", "AR100"):
        t = table(result, metric)
        lines += [f"## {metric}", "", "| K | " + " | ".join(ARM_NAMES[a] for a in arms) + " |",
                  "|---|" + "---|" * len(arms)]
        for k in result["ks"]:
            lines.append(f"| {k} | " + " | ".join(_cell(t.get(a, {}).get(k)) for a in arms)
                         + " |")
        lines.append("")
    lines += ["## What the synthetic data is worth", ""] + _findings(table(result)) + [""]
    return "\n".join(lines)


def _findings(t: dict) -> list[str]:
    """One line per K > 0: the best arm with synthetic data against real frames alone."""
    out = []
    for k in sorted(t.get("real", {})):
        real = np.mean(t["real"][k])
        best = max(("finetune", "mixed"), key=lambda a: np.mean(t.get(a, {}).get(k, [-1])))
        gain = np.mean(t[best][k]) - real
        verb = "helps" if gain > 0 else "does not help"
        out.append(f"- K = {k}: {ARM_NAMES[best]} {100 * np.mean(t[best][k]):.1f} against "
                   f"{100 * real:.1f} real only: synthetic data {verb} "
                   f"({100 * gain:+.1f} AP50)")
    return out or ["- no K > 0 was run"]


def plot(result: dict, path: Path) -> None:
    """fewshot.png: AP50 (x 100) against K per arm, the seeds' spread as error bars."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    t = table(result)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for arm, marker in zip(("real", "synthetic", "finetune", "mixed"), "osdv", strict=True):
        ks = sorted(t.get(arm, {}))
        if ks:
            v = [100 * np.asarray(t[arm][k]) for k in ks]
            ax.errorbar(ks, [x.mean() for x in v], yerr=[x.std() for x in v], marker=marker,
                        capsize=3, label=ARM_NAMES[arm])
    ax.set_xlabel("K real training frames")
    ax.set_ylabel("AP50 x 100 on the held-out real frames")
    ax.set_title("A few real frames plus sdcomp")
    ax.grid(alpha=0.3)
    ax.legend()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
