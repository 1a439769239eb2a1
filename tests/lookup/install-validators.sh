#!/bin/sh
# Shader front ends for tests/lookup (the tests skip cleanly without them): glslangValidator
# (GLSL and HLSL, Debian's glslang-tools) and the wgpu package (WGSL through naga, wgpu's shader
# compiler; it needs an adapter, e.g. Mesa's software Vulkan or GL). Non-interactive; never fails.
set -u
if ! command -v glslangValidator >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1; then
    SUDO=""
    if [ "$(id -u)" != "0" ]; then
        if command -v sudo >/dev/null 2>&1; then SUDO="sudo -n"; fi
    fi
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq >/dev/null 2>&1 || true
    $SUDO apt-get install -y -qq --no-install-recommends glslang-tools >/dev/null 2>&1 \
        || echo "tests/lookup/install-validators.sh: no glslang-tools; the GLSL/HLSL checks will skip" >&2
fi
python3 -c "import wgpu" >/dev/null 2>&1 || python3 -m pip install -q wgpu >/dev/null 2>&1 \
    || echo "tests/lookup/install-validators.sh: no wgpu; the WGSL check will skip" >&2
exit 0
