#!/usr/bin/env bash
# The paper's altitude ablation (Table 1: 626 BlueROV2 images at 10-50 m over brown water,
# X101-FPN from scratch, 1500 iterations of 2 images) on a CUDA machine, as far as LIMIT
# seconds allow; each finished cell is kept. Writes grid.json and report.md to OUT.
#     bash tools/gpu_grid.sh OUT [LIMIT]
set -uo pipefail
out=${1:?OUT folder}; limit=${2:-480}
mkdir -p "$out"
nvidia-smi --query-gpu=name,memory.total --format=csv,noheader > "$out/gpu.txt" 2>&1
nproc >> "$out/gpu.txt"
start=$(date +%s)
timeout "$limit" python3 -m sdcomp.bench grid --preset paper-table1 --device cuda \
    --out /tmp/grid --cache /tmp/grid_datasets --sprites /tmp/sprites --workers 12 \
    --threads 4 --no-progress > "$out/grid.log" 2>&1
echo "rc $? after $(( $(date +%s) - start )) s" >> "$out/grid.log"
python3 -m sdcomp.bench report /tmp/grid >> "$out/grid.log" 2>&1
cp /tmp/grid/grid.json /tmp/grid/report.md "$out/" 2>/dev/null
ls -la /tmp/grid >> "$out/grid.log" 2>&1
