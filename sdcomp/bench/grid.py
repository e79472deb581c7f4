"""The paper's ablation grid: its tables, their cells, and named presets.

A :class:`Cell` is one training: images of one BlueROV2 at an altitude over a water colour,
the paper's image count, and optionally the 137 extra green-water images of its "+G" rows.
A :class:`Table` lists (row label, cell) pairs in the paper's order; cells shared between
tables (10 m brown 626 is in Tables 1, 2 and 3) are trained once. A :class:`GridSpec` is a
preset: its tables, the scale of the image counts, the image size, the training config and
the synthetic field test set.

A :class:`RealCell` is one of Table 6's: the paper's detector trained on the user's real
labelled frames alone (500, 1000, 1500 of them), no synthetic data; a grid has Table 6 when it
is given real training frames (``bench grid --real-train``).

Presets (:data:`PRESETS`): ``paper`` (Tables 1-5), ``paper-table1`` ... ``paper-table6`` at
paper scale (626/2500 images, 416 px, X101-FPN, 1500 iterations) and ``smoke`` (every row of
every table with ~1/50 of the images at 160 px, 12 iterations, MobileNetV3: a few minutes on
a 2-core CPU, for CI).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from dataclasses import field as dc_field

from ..errors import UserError
from .datasets import DatasetPart, FieldSpec
from .train import TrainConfig

GREEN_EXTRA = 137  # the paper's "+G": green-water images added to a brown 10 m set
WATERS = ("brown", "blue", "green")
ALTITUDES = (10, 20, 30, 40, 50)


@dataclass(frozen=True)
class Cell:
    """One training: ``n`` images (the paper's count) at ``altitude`` m over ``water``
    (brown, blue, green, or mixed), plus ``green`` extra green-water images at the same
    altitude."""

    altitude: float = 10
    water: str = "brown"
    n: int = 626
    green: int = 0

    @property
    def id(self) -> str:
        g = f"+g{self.green}" if self.green else ""
        return f"alt{self.altitude:g}-{self.water}-n{self.n}{g}"


@dataclass(frozen=True)
class RealCell:
    """One training on real frames only (the paper's Table 6): ``n`` (the paper's count,
    scaled as the synthetic cells' are) of the user's labelled frames, the same seeded order
    for every cell, so each cell's frames hold the smaller cells'."""

    n: int = 500

    @property
    def id(self) -> str:
        return f"real-n{self.n}"


@dataclass(frozen=True)
class Table:
    """One of the paper's tables: ``rows`` of (label, cell); ``vary`` names what changes
    (altitude, water or size) for plots."""

    number: int
    title: str
    vary: str
    rows: tuple[tuple[str, Cell | RealCell], ...]

    @property
    def real(self) -> bool:
        """Whether the table trains on the user's real frames (Table 6)."""
        return any(isinstance(c, RealCell) for _, c in self.rows)


def _tables() -> dict[int, Table]:
    def alt(n):
        return tuple((f"{a} m", Cell(a, "brown", n)) for a in ALTITUDES)

    def colour(n):
        return tuple((w, Cell(10, w, n)) for w in WATERS)

    sizes = (("308", Cell(10, "brown", 308)), ("626", Cell(10, "brown", 626)),
             ("2500", Cell(10, "brown", 2500)),
             ("308+G", Cell(10, "brown", 308, GREEN_EXTRA)),
             ("626+G", Cell(10, "brown", 626, GREEN_EXTRA)))
    return {1: Table(1, "altitude, 626 images, brown water", "altitude", alt(626)),
            2: Table(2, "water colour, 626 images at 10 m", "water", colour(626)),
            3: Table(3, "dataset size, 10 m brown water (G = 137 green-water images)",
                     "size", sizes),
            4: Table(4, "altitude, 2500 images, brown water", "altitude", alt(2500)),
            5: Table(5, "water colour, 2500 images at 10 m", "water", colour(2500)),
            6: Table(6, "real frames only (--real-train), no synthetic data", "size",
                     tuple((str(n), RealCell(n)) for n in (500, 1000, 1500)))}


TABLES = _tables()

#: The paper's figures (AP, AP50, AP75, APs, APm, x 100; real test set), per table and row.
PAPER: dict[int, dict[str, tuple[float, ...]]] = {
    1: {"10 m": (58.41, 90.90, 72.62, 57.82, 84.72), "20 m": (47.46, 95.03, 31.28, 47.27, 57.41),
        "30 m": (32.70, 91.04, 1.41, 32.63, 40.79), "40 m": (16.81, 78.68, 0.07, 16.78, 30.76),
        "50 m": (6.87, 48.32, 0.01, 6.82, 22.50)},
    2: {"brown": (58.41, 90.90, 72.62, 57.82, 84.72), "blue": (54.72, 89.12, 65.86, 54.70, 73.88),
        "green": (57.71, 89.24, 71.33, 57.51, 78.73)},
    3: {"308": (58.90, 94.75, 72.32, 58.73, 80.59), "626": (58.41, 90.90, 72.62, 57.82, 84.72),
        "2500": (45.38, 95.52, 25.13, 45.06, 76.88),
        "308+G": (71.00, 96.42, 87.24, 70.94, 80.08),
        "626+G": (64.87, 98.27, 77.75, 65.04, 70.69)},
    4: {"10 m": (45.38, 95.52, 25.13, 45.06, 76.88), "20 m": (44.11, 93.28, 24.64, 44.01, 50.48),
        "30 m": (34.61, 91.41, 4.17, 34.67, 38.75), "40 m": (17.43, 76.85, 0.07, 17.41, 31.52),
        "50 m": (9.47, 56.27, 0.01, 9.40, 31.86)},
    5: {"brown": (45.38, 95.52, 25.13, 45.06, 76.88), "blue": (47.70, 95.49, 32.74, 47.50, 70.79),
        "green": (45.67, 95.93, 25.68, 45.39, 74.11)},
    6: {"500": (77.09, 98.97, 94.03, 76.91, 89.15), "1000": (77.56, 98.88, 95.44, 77.41, 89.81),
        "1500": (77.44, 98.84, 93.87, 77.13, 91.66)},
}
PAPER_METRICS = ("AP", "AP50", "AP75", "APs", "APm")


@dataclass(frozen=True)
class GridSpec:
    """A grid: which tables, at what scale, trained how, tested on what.

    ``size_scale`` multiplies the paper's image counts (at least ``min_images`` each);
    ``image_size`` px squares; ``seed`` seeds every cell's datasets (the green part and the
    field set use their own seeds, ``seed + 1`` and ``field.seed``).
    """

    name: str
    tables: tuple[int, ...] = (1, 2, 3, 4, 5)
    size_scale: float = 1.0
    min_images: int = 4
    image_size: int = 416
    seed: int = 0
    train: TrainConfig = dc_field(default_factory=TrainConfig)
    field: FieldSpec = dc_field(default_factory=FieldSpec)

    def __post_init__(self) -> None:
        tables = tuple(sorted(set(int(t) for t in self.tables)))
        if not tables or any(t not in TABLES for t in tables):
            raise UserError(f"tables {self.tables!r}: choose among {sorted(TABLES)}")
        object.__setattr__(self, "tables", tables)
        if isinstance(self.size_scale, bool) or not isinstance(self.size_scale, (int, float)) \
                or not (math.isfinite(self.size_scale) and 0 < self.size_scale <= 100):
            raise UserError(f"--size-scale {self.size_scale!r} is out of range: use >0 to 100")
        if not isinstance(self.min_images, int) or self.min_images < 2:
            raise UserError(f"min_images {self.min_images!r} must be a whole number >= 2")
        if isinstance(self.image_size, bool) or not isinstance(self.image_size, int) or not (
                32 <= self.image_size <= 4096):
            raise UserError(f"--image-size {self.image_size!r} is out of range: use 32 to "
                            f"4096 px")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise UserError(f"--seed {self.seed!r} must be a whole number >= 0")
        if self.field.seed in (self.seed, self.seed + 1):
            raise UserError(f"--field-seed {self.field.seed} must differ from the training "
                            f"seeds {self.seed} and {self.seed + 1}")

    def images(self, n: int) -> int:
        """Images generated for the paper's count ``n`` at this grid's scale."""
        return max(self.min_images, int(round(n * self.size_scale)))

    def rows(self) -> list[tuple[Table, str, Cell | RealCell]]:
        return [(TABLES[t], label, cell) for t in self.tables for label, cell in TABLES[t].rows]

    def cells(self) -> list[Cell | RealCell]:
        """Distinct cells in table order (a cell in several tables is trained once)."""
        return list(dict.fromkeys(cell for _, _, cell in self.rows()))

    @property
    def real(self) -> bool:
        """Whether a table of the grid trains on real frames (Table 6)."""
        return any(TABLES[t].real for t in self.tables)

    def parts(self, cell: Cell) -> list[DatasetPart]:
        """The generated datasets a cell trains on."""
        main = DatasetPart(f"alt{cell.altitude:g}-{cell.water}", cell.altitude, cell.water,
                           self.images(cell.n), self.seed, self.image_size)
        if not cell.green:
            return [main]
        return [main, DatasetPart(f"alt{cell.altitude:g}-green-extra", cell.altitude,
                                  "green", self.images(cell.green), self.seed + 1,
                                  self.image_size)]

    def to_dict(self) -> dict:
        d = asdict(self)
        d["field"]["water"] = list(self.field.water)
        d["tables"] = list(self.tables)
        return d

    def with_overrides(self, train: dict | None = None, **grid) -> GridSpec:
        """This grid with some of its fields (and its training config's) replaced."""
        spec = replace(self, **grid) if grid else self
        if train:
            spec = replace(spec, train=replace(spec.train, **train))
        return spec


_PAPER_TRAIN = TrainConfig()
_SMOKE_TRAIN = TrainConfig(backbone="mobilenet_v3-fpn", lr=0.01, max_iter=8, batch_size=2,
                           warmup_iters=2, checkpoint_every=4, proposals_train=100,
                           proposals_test=50, roi_batch=32)

PRESETS: dict[str, GridSpec] = {
    "paper": GridSpec("paper"),
    **{f"paper-table{t}": GridSpec(f"paper-table{t}", (t,)) for t in (1, 2, 3, 4, 5, 6)},
    "smoke": GridSpec("smoke", size_scale=0.02, image_size=160, train=_SMOKE_TRAIN,
                      field=FieldSpec(n=8)),
}


def preset(name: str) -> GridSpec:
    if name not in PRESETS:
        raise UserError(f"--preset {name!r} is unknown; use one of {', '.join(PRESETS)}")
    return PRESETS[name]
