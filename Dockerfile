# fibrecut: one image for the API (`fibrecut serve --workers 0`) and the workers (`fibrecut worker`).
# Not built or run on the development machine (no Docker engine there); see docs/scaling.md.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 \
    NUMBA_CACHE_DIR=/var/cache/fibrecut/numba \
    FIBRECUT_DATA=/data
RUN apt-get update && apt-get install -y --no-install-recommends libhdf5-dev && rm -rf /var/lib/apt/lists/*
WORKDIR /app
COPY pyproject.toml README.md ./
COPY solver ./solver
COPY store ./store
COPY service ./service
COPY worker ./worker
COPY cli ./cli
COPY web ./web
# the solver's kernels are compiled once, here, into NUMBA_CACHE_DIR (python -m solver.warmup)
RUN pip install --no-cache-dir '.[postgres]' \
    && useradd --create-home --uid 1000 fibrecut \
    && mkdir -p /data /var/cache/fibrecut/numba \
    && cd /tmp && python -m solver.warmup && cd /app \
    && chown -R fibrecut /data /var/cache/fibrecut
USER fibrecut
VOLUME ["/data"]
EXPOSE 8000
CMD ["fibrecut", "serve", "--host", "0.0.0.0", "--port", "8000", "--workers", "0"]
