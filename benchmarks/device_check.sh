#!/usr/bin/env bash
# The GPU checks of issue 21 as one prepared run, for a session that is lent an NVIDIA GPU
# (the `device` tool runs it in the repository root, $OUT its output folder):
#
#   1. the CPU-vs-CUDA comparisons of tests/backends/test_cuda_sim.py on the GPU itself
#      (WCSPH_CUDA_DEVICE=1: float64 to round-off in 2D and 3D, both models, the integrators,
#      the corrections, periodic walls, open boundaries, a floating body; float32 with the
#      adaptive step; particles leaving the domain; the device sort and reductions);
#   2. benchmarks/gpu.py: ms per step and fluid particle-steps per second for the cases the
#      issue names (2D 100 k and 1.6 M, SPHERIC 2 at dp 0.01, 3D 5 M), as JSON and as the
#      README's table;
#   3. benchmarks/neighbour_list.py --backend cuda: the 3D interaction pass over a neighbour
#      list with a skin against the cell walk (README, Speed);
#   4. benchmarks/floating.py --backend cuda: each stage of a floating body's step timed on the
#      device (issue 22's goal: the body's stages under 10 % of the step), `floating_box_2d` at
#      98 k fluid particles and `floating_box_waves_3d`, both models.
#
# The device's image has numba, numba-cuda, numpy, matplotlib, scikit-image, rich, pytest and
# hypothesis (see the device tool's KINDS.md); what it lacks travels as wheels in .whl/ (git
# ignores it), made here beforehand for its Python 3.12:
#
#   echo /.whl/ >> .git/info/exclude
#   python3 -m pip download --no-deps --only-binary=:all: --python-version 3.12 \
#       --implementation cp --platform manylinux2014_x86_64 -d .whl meshio==5.3.5
#
# and the call names .whl in `carry`, e.g. with a limit that leaves time to rerun:
#   bash benchmarks/device_check.sh tests      (part 1 alone: 4 minutes at most, timeout_s 300)
#   bash benchmarks/device_check.sh speed      (part 2: 6 minutes at most, timeout_s 420)
#   bash benchmarks/device_check.sh list       (part 3: 4.5 minutes at most, timeout_s 330)
#   bash benchmarks/device_check.sh floating   (part 4: 8 minutes at most, timeout_s 540)
# one call each (all four, the default, can take 22.5 minutes: more than one call may run)
# Each part is bounded by its own timeout, and its output goes to $OUT as it runs.
set -u
PART=${1:-all}
OUT=${OUT:-runs/device_check}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1
if ls .whl/*.whl >/dev/null 2>&1; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl \
        && export PYTHONPATH=/tmp/site
fi
export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}"
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv; python3 -c "import numba, numba_cuda; print('numba', numba.__version__, 'numba-cuda', numba_cuda.__version__)"; } 2>&1 | tee "$OUT/machine.txt"

if [ "$PART" = all ] || [ "$PART" = tests ]; then
WCSPH_CUDA_DEVICE=1 timeout 240 python3 -m pytest -q -p no:cacheprovider -o addopts="" -n 4 \
    tests/backends/test_cuda_sim.py -k "not benchmark and not reads_the_device_once" 2>&1 | tee "$OUT/tests.log"
fi

if [ "$PART" = all ] || [ "$PART" = speed ]; then
timeout 240 python3 benchmarks/gpu.py --json 2>&1 | tee "$OUT/gpu.jsonl"
timeout 120 python3 benchmarks/gpu.py --json --constant-dt --cases 2d-100k spheric2 2>&1 | tee -a "$OUT/gpu.jsonl"
fi

# 3. a neighbour list with a skin against the cell walk, the 3D interaction pass alone
#    (README, Speed): SPHERIC 2 at dp 0.01 and the 3D dam break at 1 M, float32
if [ "$PART" = all ] || [ "$PART" = list ]; then
for s in 0.05 0.1; do
    timeout 90 python3 benchmarks/neighbour_list.py spheric2_3d --n 652000 --backend cuda --skin $s 2>&1 | tee -a "$OUT/neighbour_list.txt"
done
timeout 90 python3 benchmarks/neighbour_list.py dam_break_3d_bi --n 1000000 --backend cuda --skin 0.05 2>&1 | tee -a "$OUT/neighbour_list.txt"
fi

# 4. the floating body's stages on the device, each timed whole (synchronised after each)
if [ "$PART" = all ] || [ "$PART" = floating ]; then
timeout 240 python3 benchmarks/floating.py --backend cuda 2>&1 | tee -a "$OUT/floating.txt"
timeout 240 python3 benchmarks/floating.py --backend cuda --case floating_box_waves_3d --steps 20 2>&1 | tee -a "$OUT/floating.txt"
fi
