"""The results folder as markdown tables (the paper's layout, its figures beside ours) and
PNG plots (AP vs altitude, AP by water colour, AP vs dataset size).

Reads ``OUT/grid.json`` and ``OUT/cells/*.json`` (:mod:`.runner`), writes::

    OUT/report.md                 one table per paper table, test set named in each
    OUT/plots/ap_vs_altitude.png  Tables 1 and 4: AP and AP50 (ours, paper dashed) vs metres
    OUT/plots/ap_by_water.png     Tables 2 and 5: AP50 per water colour, ours beside the paper
    OUT/plots/ap_vs_size.png      Table 3: AP and AP50 vs training images (+G marked), and
                                  Table 6's real-only AP50 where the grid ran it

Figures are percentages (x 100) with two decimals, as the paper prints them; ``-`` marks a
metric COCO leaves undefined (-1 in the JSON) and ``(not run)`` a row without results.
"""

from __future__ import annotations

import io
import json
import textwrap
from pathlib import Path
from typing import Any

from ..errors import UserError
from ..util.files import atomic_write_bytes
from .evaluate import METRICS
from .grid import PAPER, PAPER_METRICS, TABLES, Cell
from .runner import read_cell

PLOTS = ("ap_vs_altitude.png", "ap_by_water.png", "ap_vs_size.png")


def load_results(out: str | Path) -> tuple[dict, dict[tuple[int, str], dict]]:
    """``(grid meta, {(table, row label): cell JSON})`` of a results folder."""
    out = Path(out)
    try:
        meta = json.loads((out / "grid.json").read_text())
    except FileNotFoundError:
        raise UserError(f"{out}: no grid.json here; run `python -m sdcomp.bench grid --out "
                        f"{out}` first") from None
    except (OSError, ValueError) as e:
        raise UserError(f"{out}/grid.json: not readable ({e})") from None
    rows: dict[tuple[int, str], dict] = {}
    for path in sorted((out / "cells").glob("*.json")):
        data = read_cell(path)
        if data is None:
            continue
        for table, label in data.get("rows", []):
            rows[(int(table), str(label))] = data
    return meta, rows


def _pct(v: float | None) -> str:
    if v is None:
        return ""
    return "-" if v < 0 else f"{100 * v:.2f}"


def markdown(meta: dict, rows: dict[tuple[int, str], dict]) -> str:
    """The report: a header naming grid, test set and device, then one table per paper table
    with our test metrics, our synthetic-val AP50, and the paper's five figures."""
    grid = meta.get("grid", {})
    train = grid.get("train", {})
    lines = [f"# Detector benchmark: grid `{grid.get('name', '?')}`", "",
             f"- test set: **{meta.get('test_set', '?')}**",
             f"- detector: Faster R-CNN, backbone `{train.get('backbone')}`, weights "
             f"`{train.get('weights')}`, {train.get('optimizer')} lr {train.get('lr')}, "
             f"{train.get('max_iter')} iterations of {train.get('batch_size')} images, "
             f"{grid.get('image_size')} px",
             f"- image counts: the paper's x {grid.get('size_scale')} (at least "
             f"{grid.get('min_images')})",
             f"- device: {meta.get('device', '?')}", ""]
    cells = {d["cell"]: d for d in rows.values()}
    if cells:
        total = sum(d["wall_time_s"]["total"] for d in cells.values())
        lines += [f"- {len(cells)} cells, {total:.0f} s of cell wall time "
                  f"(datasets + training + scoring)", ""]
    lines += ["Ours: COCO metrics x 100 on the test set above; `val AP50`: our synthetic "
              "validation split. Paper: Lin et al. 2023, X101-FPN, real test frames.", ""]
    for number in grid.get("tables", []):
        table = TABLES[int(number)]
        head = ["row", "train images", *METRICS, "val AP50", "", *(f"paper {m}" for m in
                                                            PAPER_METRICS)]
        lines += [f"## Table {table.number}: {table.title}", "",
                  f"test set: {meta.get('test_set', '?')}", "",
                  "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for label, _ in table.rows:
            data = rows.get((table.number, label))
            paper = PAPER.get(table.number, {}).get(label, ())
            if data is None:
                ours = ["(not run)", *[""] * (len(METRICS) + 1)]  # metrics, val AP50
            else:
                m = data["test"]["metrics"]
                val = data.get("val")
                ours = [str(data.get("train_images", "")), *(_pct(m[k]) for k in METRICS),
                        "-" if val is None else _pct(val["metrics"]["AP50"])]
            lines.append("| " + " | ".join([label, *ours, "", *(f"{p:.2f}" for p in paper)])
                         + " |")
        lines.append("")
    if 6 in grid.get("tables", []):
        return "\n".join(lines)
    lines += ["## Table 6 (the paper's only): trained on real frames, no synthetic data", "",
              "Needs your labelled real training frames (`--real-train FILE "
              "--real-train-images DIR`); printed for comparison.", "",
              "| real training images | " + " | ".join(f"paper {m}" for m in PAPER_METRICS)
              + " |", "|" + "---|" * (len(PAPER_METRICS) + 1)]
    lines += [f"| {label} | " + " | ".join(f"{p:.2f}" for p in vals) + " |"
              for label, vals in PAPER[6].items()]
    return "\n".join(lines)


def _series(rows, table: int, metric: str) -> list[Any]:
    """Our figures of ``metric`` (x 100) per row of ``table``; None where there is none
    (matplotlib leaves a gap)."""
    out: list[Any] = []
    for label, _ in TABLES[table].rows:
        data = rows.get((table, label))
        v = None if data is None else data["test"]["metrics"][metric]
        out.append(None if v is None or v < 0 else 100 * v)
    return out


def _cells(table: int) -> list[Cell]:
    """The synthetic cells of ``table``'s rows (Tables 1-5), in order."""
    cells = [c for _, c in TABLES[table].rows]
    assert all(isinstance(c, Cell) for c in cells), table
    return [c for c in cells if isinstance(c, Cell)]


def _save(fig, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    atomic_write_bytes(path, buf.getvalue())


def plots(meta: dict, rows: dict, folder: Path) -> list[Path]:
    """The three PNG plots (written atomically); returns their paths."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    tables = set(meta.get("grid", {}).get("tables", []))
    label = meta.get("test_set", "?")
    written = []
    for name, draw in zip(PLOTS, (_plot_altitude, _plot_water, _plot_size), strict=True):
        fig, ax = plt.subplots(figsize=(7, 4.5))
        draw(ax, rows, tables, label)
        _save(fig, folder / name)
        written.append(folder / name)
        plt.close(fig)
    return written


def _plot_altitude(ax, rows: dict, tables: set, label: str) -> None:
    """AP vs altitude (Tables 1 and 4): our AP50 and AP of the tables in ``tables`` (x 100,
    per metre of altitude), the paper's AP50 dashed; ``label`` names the test set."""
    for t, colour in ((1, "tab:blue"), (4, "tab:orange")):
        alts = [c.altitude for c in _cells(t)]
        n = _cells(t)[0].n
        if t in tables:
            ax.plot(alts, _series(rows, t, "AP50"), "o-", color=colour, label=f"ours AP50, {n}")
            ax.plot(alts, _series(rows, t, "AP"), "s-", color=colour, alpha=0.5,
                    label=f"ours AP, {n}")
        paper = [PAPER[t][lbl] for lbl, _ in TABLES[t].rows]
        ax.plot(alts, [p[1] for p in paper], "o--", color=colour, alpha=0.6, mfc="none",
                label=f"paper AP50, {n}")
    _finish(ax, "altitude (m)", "AP x 100", f"AP vs altitude (test: {label})")


def _plot_water(ax, rows: dict, tables: set, label: str) -> None:
    """AP50 by water colour (Tables 2 and 5): bars of ours (x 100; none for a table not in
    ``tables``) beside the paper's, hatched; ``label`` names the test set."""
    bars = [(t, who) for t in (2, 5) for who in ("ours", "paper")]
    width = 0.8 / len(bars)
    for k, (t, who) in enumerate(bars):
        n = _cells(t)[0].n
        if who == "ours":
            vals = _series(rows, t, "AP50") if t in tables else [None] * 3
        else:
            vals = [PAPER[t][w][1] for w, _ in TABLES[t].rows]
        xs = [i + (k - (len(bars) - 1) / 2) * width for i in range(3)]
        ax.bar(xs, [v if v is not None else 0 for v in vals], width,
               label=f"{who} AP50, {n}", hatch="//" if who == "paper" else None,
               alpha=0.6 if who == "paper" else 1.0)
    ax.set_xticks(range(3), [w for w, _ in TABLES[2].rows])
    _finish(ax, "water colour", "AP50 x 100", f"AP50 by water colour (test: {label})")


def _plot_size(ax, rows: dict, tables: set, label: str) -> None:
    """AP and AP50 vs dataset size (Table 3, log x: the paper's image counts, +G rows
    marked apart), ours (x 100, if table 3 is in ``tables``) and the paper's dashed, and
    Table 6's real-only AP50 (ours and the paper's) if it is in ``tables``; ``label``
    names the test set."""
    sizes = [c.n + c.green for c in _cells(3)]
    plain = [i for i, c in enumerate(_cells(3)) if not c.green]
    green = [i for i, c in enumerate(_cells(3)) if c.green]
    paper = [PAPER[3][lbl] for lbl, _ in TABLES[3].rows]
    for metric, idx, marker in (("AP50", 1, "o"), ("AP", 0, "s")):
        ours = _series(rows, 3, metric) if 3 in tables else [None] * len(sizes)
        ax.plot([sizes[i] for i in plain], [ours[i] for i in plain], marker + "-",
                color="tab:blue", label=f"ours {metric}")
        ax.plot([sizes[i] for i in green], [ours[i] for i in green], marker,
                color="tab:green", ms=9, label=f"ours {metric} +G")
        ax.plot([sizes[i] for i in plain], [paper[i][idx] for i in plain], marker + "--",
                color="gray", mfc="none", label=f"paper {metric}")
        ax.plot([sizes[i] for i in green], [paper[i][idx] for i in green], marker,
                color="gray", mfc="none", ms=9, label=f"paper {metric} +G")
    if 6 in tables:  # Table 6: real frames only, the paper's counts
        real = [int(lbl) for lbl, _ in TABLES[6].rows]
        ax.plot(real, _series(rows, 6, "AP50"), "^-", color="tab:red",
                label="ours AP50, real only")
        ax.plot(real, [PAPER[6][str(n)][1] for n in real], "^--", color="tab:red",
                mfc="none", alpha=0.6, label="paper AP50, real only")
    ax.set_xscale("log")
    ax.set_xticks(sizes, [lbl for lbl, _ in TABLES[3].rows], fontsize=7)
    ax.minorticks_off()
    _finish(ax, "training images (paper's count; + 137 green for +G)", "AP x 100",
            f"AP vs dataset size (test: {label})")


def _finish(ax, xlabel: str, ylabel: str, title: str) -> None:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_ylim(0, 125)  # room for the legend above the data
    ax.set_yticks(range(0, 101, 20))
    ax.set_title("\n".join(textwrap.wrap(title, 90)), fontsize=8)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=4, loc="upper center")
    ax.figure.tight_layout()


def write_report(out: str | Path) -> dict[str, Path]:
    """Write ``report.md`` and the plots of the results folder ``out``; returns their paths."""
    out = Path(out)
    meta, rows = load_results(out)
    md = out / "report.md"
    atomic_write_bytes(md, (markdown(meta, rows) + "\n").encode())
    written = {"report": md}
    for p in plots(meta, rows, out / "plots"):
        written[p.stem] = p
    return written
