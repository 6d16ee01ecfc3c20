#!/usr/bin/env bash
# Run the benchmark suite on a lent GPU machine (issue #9, point 5) in one short call.
#
# The machine has JAX (CUDA), diffrax, equinox, optimistix, scipy, xarray and matplotlib but no
# network: the peers (Pinocchio, MuJoCo, modern_robotics) and h5netcdf travel as a pre-installed
# Python 3.12 site folder, `.site/site312.tgz` (ignored by git), built on the developer's machine:
#   pip download --no-deps --only-binary=:all: --python-version 3.12 --platform manylinux_2_28_x86_64 \
#       --platform any -d .whl pin libpinocchio coal libcoal eigenpy cmeel cmeel-boost cmeel-urdfdom \
#       cmeel-console-bridge cmeel-tinyxml2 cmeel-octomap cmeel-qhull cmeel-zlib cmeel-assimp \
#       mujoco mujoco-core glfw pyopengl modern_robotics h5netcdf \
#       mujoco-mjx trimesh etils absl-py          (versions as in the local venv; mujoco-mjx for the
#       nets benchmark's MJX row, which runs wherever JAX has a GPU)
#   pip install --no-deps --target /tmp/site312 --python-version 3.12 --only-binary=:all: \
#       --platform manylinux_2_28_x86_64 --platform any .whl/*.whl
#   then delete cmeel.prefix/{include,share,bin}, static libraries and the shared libraries no extension
#   module needs (readelf -d ... NEEDED, transitively) to stay under the 64 MiB transfer limit, and
#   tar czf .site/site312.tgz -C /tmp/site312 .
# origami_jax itself is used from the working tree.
#
# Every benchmark runs under its own `timeout` so that one slow peer cannot eat the whole lease;
# each writes its own JSON and Markdown into $OUT (default ./device_out) as soon as it finishes.
#
#   bash benchmarks/device_run.sh            # on the device machine, from the repository root
#   ONLY="sweep simulate" bash benchmarks/device_run.sh   # some of them
set -u
OUT=${OUT:-$PWD/device_out}
mkdir -p "$OUT"
PY=${PY:-python3}
# Or, simpler, the missing packages as wheels in `.whl/` (ignored by git; the device README's recipe:
# pip download --no-deps --only-binary=:all: --python-version 3.12 ... -d .whl mujoco==4.0.1
# mujoco-core==4.0.1 mujoco-mjx==3.17.0 glfw pyopengl trimesh h5netcdf), carried with the call.
if ls .whl/*.whl >/dev/null 2>&1; then
    $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit
    export PYTHONPATH=/tmp/site:$PWD
fi
# A rerun on the same (warm) machine reuses what the first run compiled.
export JAX_COMPILATION_CACHE_DIR=${JAX_COMPILATION_CACHE_DIR:-/tmp/jax_cache}
if [ -f .site/site312.tgz ] && [ "$($PY -c 'import sys; print(sys.version_info[:2] == (3, 12))')" = True ]; then
    mkdir -p /tmp/site && tar xzf .site/site312.tgz -C /tmp/site
    export PYTHONPATH=/tmp/site:/tmp/site/cmeel.prefix/lib/python3.12/site-packages:$PWD
    export LD_LIBRARY_PATH=/tmp/site/cmeel.prefix/lib:/tmp/site/cmeel.prefix/lib64:${LD_LIBRARY_PATH:-}
fi
export PYTHONUNBUFFERED=1
{
    nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.sm --format=csv
    $PY -c "import jax, diffrax, equinox, optimistix; print('jax', jax.__version__, jax.devices()); print('diffrax', diffrax.__version__, 'equinox', equinox.__version__, 'optimistix', optimistix.__version__)"
    $PY -c "import mujoco; print('mujoco', mujoco.__version__)"
    $PY -c "import pinocchio; print('pinocchio', pinocchio.__version__)"
} 2>&1 | tee "$OUT/env.txt"

run() {  # run NAME SECONDS [extra args]
    local name=$1 seconds=$2
    shift 2
    if [ -n "${ONLY:-}" ] && [[ " $ONLY " != *" $name "* ]]; then return; fi
    echo "== $name (limit ${seconds}s) $(date +%T)"
    timeout "$seconds" $PY -m benchmarks --only "$name" --json "$OUT/gpu_$name.json" \
        --markdown "$OUT/gpu_$name.md" ${BENCH_ARGS:-} "$@" 2>&1 | tee -a "$OUT/log.txt"
}
run chain 90 --figure "$OUT/throughput_gpu.png"
run sweep 170
run unfold 90
run simulate 90
run chain_peers 60
run design 150
run net ${NET_LIMIT:-420}  # ours and MJX over the same 1,000 scattered cube nets (--quick: 64) on the GPU
# the fixed-step engine and the adaptive one over a scattered batch against C MuJoCo on the host's cores
export ENGINE_BATCH=${ENGINE_BATCH:-256}
run engine ${ENGINE_LIMIT:-400}
echo "done $(date +%T)"
