#!/usr/bin/env bash
# A study on a lent 16-core machine (PLAN in STUDY, default plan-limited-device.json in this
# script's folder): demcal from
# the source tree with its bench entry points declared by a dist-info shim (nothing to
# install), JOBS runs at once (default 5), each result in $OUT/results.jsonl as it finishes.
set -u
site=/tmp/demcal-site; info=$site/demcal-0.dev0.dist-info
mkdir -p "$info"
printf 'Metadata-Version: 2.1\nName: demcal\nVersion: 0.dev0\n' > "$info/METADATA"
printf '[demcal.benches]\nrepose = demcal.bench.repose\nincline = demcal.bench.incline\nimpact = demcal.bench.impact\n' > "$info/entry_points.txt"
export PYTHONPATH=$PWD/src:$site PYTHONUNBUFFERED=1
here=${STUDY:-benchmarks/studies/bench-profiles-2026-11-25}
nproc; lscpu | grep -i "model name"
python3 -c "import numba, numpy, scipy; print('numba', numba.__version__, 'numpy', numpy.__version__, 'scipy', scipy.__version__)"
[ "${SMOKE:-1}" = 1 ] && { python3 -m demcal bench impact --json | head -c 200; echo; }
timeout "${LIMIT:-530}" python3 benchmarks/bench_study.py "$here/${PLAN:-plan-limited-device.json}" "$OUT/results.jsonl" \
    --jobs "${JOBS:-5}" --separate-caches /tmp/demcal-caches
echo "study exit $?"
