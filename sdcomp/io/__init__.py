"""Stage 6, files: the dataset folder and its formats.

- :mod:`~sdcomp.io.layout`: :class:`DatasetLayout` (every path) and the one dataset reader;
- :mod:`~sdcomp.io.journal`: ``records.jsonl``, one record per finished image;
- :mod:`~sdcomp.io.writers`: the label writers (:mod:`~sdcomp.io.coco`,
  :mod:`~sdcomp.io.yolo`) behind one interface;
- :mod:`~sdcomp.io.png`: 16-bit PNG instance masks.
"""
