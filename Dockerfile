# fenics-plast on Debian bookworm: the whole stack (FEniCSx, PETSc, MPI, numba) from Debian packages.
FROM debian:bookworm

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
