# bsdf-tab HTTP service: docker build -t bsdf-tab . && docker run -p 8000:8000 bsdf-tab
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    WARP_CACHE_PATH=/opt/bsdf-tab/warp-cache \
    BSDF_TAB_CACHE_DIR=/var/cache/bsdf-tab \
    BSDF_TAB_HOST=0.0.0.0 \
    BSDF_TAB_PORT=8000

# Warp compiles CPU kernels with its bundled Clang/LLVM; it needs a C++ runtime only.
RUN apt-get update \
    && apt-get install -y --no-install-recommends libstdc++6 \
    && rm -rf /var/lib/apt/lists/*

RUN groupadd --system bsdf && useradd --system --gid bsdf --home-dir /home/bsdf --create-home bsdf

WORKDIR /opt/bsdf-tab/src
COPY pyproject.toml README.md ./
COPY bsdf_tab ./bsdf_tab
COPY service ./service
RUN pip install . && rm -rf /opt/bsdf-tab/src/build

# Compile every table kind's Warp kernels now, into WARP_CACHE_PATH, so the first request does
# not pay for it (one tiny table per kind: same kernels as any size).
RUN mkdir -p "$WARP_CACHE_PATH" "$BSDF_TAB_CACHE_DIR" \
    && cd / && python -m service.warmup cpu
RUN chown -R bsdf:bsdf "$WARP_CACHE_PATH" "$BSDF_TAB_CACHE_DIR"

USER bsdf
WORKDIR /home/bsdf
VOLUME ["/var/cache/bsdf-tab"]
EXPOSE 8000

HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD python -c "import os, urllib.request; urllib.request.urlopen(f'http://127.0.0.1:{os.environ.get(\"BSDF_TAB_PORT\", \"8000\")}/healthz', timeout=4).read()" || exit 1

CMD ["bsdf-tab", "serve"]
