"""On-the-fly training data: ``SyntheticDetection`` through a 2-worker DataLoader at 416x416
(pytest-benchmark; the figure goes to ``extra_info``).

Target from the integration issue: >= 1000 images/s on the 2-core development machine, so
that a detector never waits for data. The assert is a sanity floor far below the target (a
loaded CI machine must not fail: it is scaled by the ``machine`` fixture's slowdown); the
measured rate is printed and stored. Measured with the
default float32 images and with ``image_dtype=torch.uint8`` (a quarter of the bytes from the
workers to the main process).
"""

from __future__ import annotations

import pytest

torch = pytest.importorskip("torch")

from sdcomp.pipeline import Generator  # noqa: E402
from sdcomp.scene.config import GeneratorConfig  # noqa: E402
from sdcomp.torch_datasets import SyntheticDetection, collate  # noqa: E402

TARGET = 400.0  # images/s, uint8 (the speed issue)
BATCH = 16
WARM_BATCHES = 4  # worker start-up (each builds its generator) is not throughput


@pytest.mark.parametrize("image_dtype", [torch.float32, torch.uint8],
                         ids=["float32", "uint8"])
def test_bench_dataloader_416_two_workers(benchmark, machine, sprites_dir, image_dtype):
    """Default config (416x416, 1-3 BlueROV2s, clutter), CHW images and targets with
    masks, batches of 16, 2 worker processes, read by the main process."""
    config = GeneratorConfig(seed=1)
    Generator(config, sprites_dir, progress=False)  # atlases built before the workers start
    batches = 24
    dataset = SyntheticDetection(config, (batches + WARM_BATCHES) * BATCH * 4,
                                 sprites_dir=sprites_dir, image_dtype=image_dtype)
    loader = torch.utils.data.DataLoader(dataset, batch_size=BATCH, num_workers=2,
                                         collate_fn=collate, persistent_workers=True,
                                         prefetch_factor=4, timeout=300)
    it = iter(loader)
    for _ in range(WARM_BATCHES):
        next(it)

    def take():
        n = 0
        for _ in range(batches):
            images, _targets = next(it)
            n += len(images)
        return n

    n = benchmark.pedantic(take, rounds=1, iterations=1)
    rate = n / benchmark.stats.stats.mean
    benchmark.extra_info.update(images=n, images_per_s=round(rate, 1),
                                target_images_per_s=TARGET, image_dtype=str(image_dtype))
    slowdown = machine.measure_after()
    print(f"\nSyntheticDetection, 2-worker DataLoader, 416x416, {image_dtype}: {rate:.0f} "
          f"images/s (target {TARGET:.0f}; this machine {slowdown:.2f}x slower than the "
          "reference)")
    assert rate > machine.floor(20)  # 85-98/s at rest
