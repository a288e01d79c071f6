#!/usr/bin/env bash
# The cuda backend on a lent GPU, in one call: versions, correctness against the cpu
# backend on the same machine, throughput, every sub-model compiled for the device,
# a paper-profile funnel run's progress, ensembles; JSON lines under $OUT, a table
# printed last.
# demcal runs from the source tree (bench entry points from a dist-info shim, nothing
# installed). The settled 5,000-particle packings travel in benchmarks/.packings/.
set -u
OUT=${OUT:-/tmp/gpu-out}; mkdir -p "$OUT"
site=/tmp/demcal-site; info=$site/demcal-0.dev0.dist-info; mkdir -p "$info"
printf 'Metadata-Version: 2.1\nName: demcal\nVersion: 0.dev0\n' > "$info/METADATA"
printf '[demcal.benches]\nrepose = demcal.bench.repose\nincline = demcal.bench.incline\nimpact = demcal.bench.impact\n' > "$info/entry_points.txt"
export PYTHONPATH=$PWD/src:$site PYTHONUNBUFFERED=1 NUMBA_CACHE_DIR=/tmp/numba-cache
here=benchmarks/gpu
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
  lscpu | grep -i "model name"; nproc
  python3 -c "import numba, numpy, importlib.metadata as m; print('numba', numba.__version__, 'numba-cuda', m.version('numba-cuda'), 'numpy', numpy.__version__)"
} 2>&1 | tee "$OUT/machine.txt"
t0=$(date +%s)
# the CPU engine's models compile on spare cores meanwhile (numba's disk cache)
python3 $here/warm.py > "$OUT/warm.err" 2>&1 &
# 1. correctness first: cuda against cpu (16 threads) on this machine, and cuda twice
timeout "${T_CHECK:-90}" python3 $here/check.py --particles 400 --steps 100 400 1500 \
    --threads 16 --cases 2 --out "$OUT/check.jsonl" 2>"$OUT/check.err"; echo "check exit $? at $(( $(date +%s) - t0 )) s"
# 2. throughput: spheres 1e6, 4e6, 1e5 (cuda), then 1e6 on the cpu backend (16 cores)
timeout "${T_SIZES:-130}" python3 $here/sizes.py "$OUT/throughput.jsonl" --backend cuda \
    --particles 1000000 4000000 100000 --steps 200 2>"$OUT/sizes.err"; echo "sizes exit $? at $(( $(date +%s) - t0 )) s"
timeout "${T_CPU:-50}" python3 $here/sizes.py "$OUT/throughput.jsonl" --backend cpu \
    --particles 1000000 --steps 30 --threads 16 2>>"$OUT/sizes.err"; echo "cpu exit $? at $(( $(date +%s) - t0 )) s"
# this machine's CPU is another model: the CPU engine's bits of benchmarks/bits.py, on
# spare cores while the device runs (compare at home with a run of bits.py at the same
# commit, docs/performance.md "The same bits for every x86-64 compile target")
timeout "${T_BITS:-240}" python3 benchmarks/bits.py --out "$OUT/bits-cpu.json" > "$OUT/bits.log" 2>&1 &
bits_pid=$!
timeout "${T_CLUMPS:-60}" python3 $here/sizes.py "$OUT/throughput.jsonl" --backend cuda \
    --particles 1000000 --steps 200 --clumps 2>>"$OUT/sizes.err"; echo "clumps exit $? at $(( $(date +%s) - t0 )) s"
# 3. the paper-profile funnel on the device: as far as it gets
timeout "${T_FUNNEL:-60}" python3 -m demcal bench repose-funnel --profile paper --backend cuda \
    > "$OUT/funnel.txt" 2>&1; echo "funnel exit $? at $(( $(date +%s) - t0 )) s"
# 4. every sub-model and wall kind of the simulator tests, compiled for the device
[ "${CASES:-1}" = 1 ] && timeout "${T_CASES:-60}" python3 tests/dem/cuda_sim_cases.py 30 > "$OUT/cases.jsonl" 2>"$OUT/cases.err"; echo "cases exit $? at $(( $(date +%s) - t0 )) s"
# 5. ensembles: three systems together against each alone, compiled for the device
#    (bits), then a design's small runs alone and as one ensemble (bits and wall times)
timeout "${T_ENSEMBLE_BITS:-45}" python3 tests/dem/cuda_sim_ensemble.py > "$OUT/ensemble-bits.jsonl" 2>"$OUT/ensemble.err"; echo "ensemble bits exit $? at $(( $(date +%s) - t0 )) s"
timeout "${T_ENSEMBLE:-60}" python3 $here/ensemble.py "$OUT/ensemble.jsonl" --test impact --profile tiny --runs 8 2>>"$OUT/ensemble.err"; echo "ensemble exit $? at $(( $(date +%s) - t0 )) s"
wait $bits_pid; echo "bits exit $? at $(( $(date +%s) - t0 )) s"
python3 $here/table.py "$OUT"
