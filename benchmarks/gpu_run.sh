#!/usr/bin/env bash
# `dvr bench gpu` on a lent GPU machine, from a copy of the working tree (docs/gpu.md).
#
# The device machine reaches no package registry: what dvr-gl needs beyond its image (moderngl, glcontext,
# tomli-w; setuptools to build dvr-gl's entry points) travels as wheels in .whl/, and the GL loaders (libEGL,
# libglvnd) as Debian packages in .gl/; both folders are ignored by git and named in the run's `carry`.
#
#   here, once, with network:  benchmarks/gpu_run.sh --prepare
#   there (the device tool):   command "bash benchmarks/gpu_run.sh", carry [".whl", ".gl"], timeout_s 540
#   here, to try it on llvmpipe: PYTHON=.venv/bin/python benchmarks/gpu_run.sh --volume-size 32 --size 64
#
# Any other arguments go to `dvr bench gpu` (default: 512^3 to 1024x1024 in a 300 s budget). It writes
# gpu-bench.md, gpu-bench.json and this run's log gpu-run.log into $OUT (default ./gpu-out).
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
PY_VERSION=${PY_VERSION:-3.12}    # the device image's Python (KINDS.md: 3.12.3)
WHEELS="moderngl==5.13.0 glcontext==3.1.0 tomli-w==1.2.0 setuptools==84.2.1"
GL_DEBS="libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2"
NVIDIA_EGL=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json

ignore() {  # keep a carried folder out of git without touching .gitignore
    grep -qx "/$1/" .git/info/exclude 2>/dev/null || echo "/$1/" >> .git/info/exclude
}

prepare() {
    ignore .whl
    ignore .gl
    mkdir -p .whl .gl /tmp/amd64/partial
    local platforms=""
    for n in 28 27 17; do platforms="$platforms --platform manylinux_2_${n}_x86_64"; done
    # shellcheck disable=SC2086
    "$PYTHON" -m pip download -q --no-deps --only-binary=:all: --python-version "$PY_VERSION" --implementation cp \
        $platforms --platform manylinux2014_x86_64 --platform any -d .whl $WHEELS
    local o="-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64"
    # shellcheck disable=SC2086
    apt-get $o update -qq && (cd .gl && apt-get $o download $GL_DEBS)
    ls -l .whl .gl
}

install() {  # into /tmp/site: the wheels, then dvr-gl itself (its entry points name the renderers)
    if [ -d .gl ] && [ "$(id -u)" = 0 ] && ls .gl/*.deb >/dev/null 2>&1; then
        for f in .gl/*.deb; do dpkg -x "$f" /; done
        ldconfig
    fi
    if [ -f "$NVIDIA_EGL" ]; then  # EGL through NVIDIA's vendor library (the device README's advice)
        export __EGL_VENDOR_LIBRARY_FILENAMES="$NVIDIA_EGL"
        export LD_LIBRARY_PATH="/usr/local/nvidia/lib64:/usr/local/nvidia/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    fi
    local site=/tmp/dvr-gl-site
    "$PYTHON" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target "$site" .whl/*.whl
    "$PYTHON" -m pip install -q --no-index --find-links .whl --no-deps --no-cache-dir --upgrade --target "$site" .
    export PYTHONPATH="$site${PYTHONPATH:+:$PYTHONPATH}"
}

if [ "${1:-}" = "--prepare" ]; then
    prepare
    exit 0
fi

out=${OUT:-gpu-out}
mkdir -p "$out"
{
    date -u
    command -v nvidia-smi >/dev/null && nvidia-smi || echo "no nvidia-smi"
    install
    export DVR_GL_BACKEND=${DVR_GL_BACKEND:-egl}
    # the bench keeps its --time-budget; this stops it if a step overruns badly, so that the log comes back
    timeout "${GPU_BENCH_TIMEOUT:-480}" "$PYTHON" -m dvr_gl bench gpu --out "$out" --overwrite "$@"
} 2>&1 | tee "$out/gpu-run.log"
exit "${PIPESTATUS[0]}"
