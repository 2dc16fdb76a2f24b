# fenics-plast on Debian: the whole stack (FEniCSx, PETSc, MPI, numba) from Debian packages.
# Builds on Debian 13 trixie (FEniCSx 0.9.0, the default) or Debian 12 bookworm (FEniCSx 0.5.2):
#   docker build --build-arg DEBIAN_RELEASE=bookworm -t fenics-plast .
# trixie is the default for reproducible benchmarks: Debian's stable release, supported longest, and
# as fast or faster on our benchmarks with the same results (docs/PLATFORMS.md).
# scripts/fresh_root_check.sh runs these steps on a fresh root of each release.
ARG DEBIAN_RELEASE=trixie
FROM debian:${DEBIAN_RELEASE}

RUN apt-get update \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
        make git ca-certificates python3 python3-venv \
 && rm -rf /var/lib/apt/lists/*

WORKDIR /opt/fenics-plast
COPY . .
# Remove any host venv/results that slipped into the build context, then install.
RUN rm -rf .venv results && bash scripts/install.sh && rm -rf /var/lib/apt/lists/*

ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
CMD ["make", "demo"]
