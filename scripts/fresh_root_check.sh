#!/usr/bin/env bash
# Fresh-root check: do what a new user does on a minimal Debian bookworm, and fail if any step fails.
#
#   1. build a minimal bookworm root with `debootstrap --variant=minbase` (what the debian:bookworm
#      image of our Dockerfile starts from), with the same apt sources as that image;
#   2. copy the checkout into it (the files git tracks, as they are in the work tree: a file that was
#      never `git add`ed is missing here as it would be in a clone);
#   3. run in it, with chroot, the Dockerfile's own steps: this script reads the Dockerfile and runs
#      its WORKDIR, ENV and RUN lines (COPY . . is step 2), so the two cannot drift apart;
#   4. run the README's two commands there: `make demo`, then `make test`.
#
# /proc, /sys and /dev are mounted in the root and always unmounted (trap), also when a step fails;
# the root is then deleted. Downloaded .deb files are kept between runs in FRESH_ROOT_CACHE (default
# /var/cache/fenics-plast-fresh), so a second run downloads nothing; the root itself is new every time.
#
# Needs root (debootstrap, mount, chroot); apt-installs debootstrap on the host if it is missing.
# Each step's output is in $FRESH_ROOT_CACHE/logs/ (the last run's); a failing step prints its tail.
# Environment: FRESH_ROOT_CACHE, FRESH_ROOT_TMP (where the root is made, default /var/tmp),
# FRESH_ROOT_MIRROR (default http://deb.debian.org/debian), FRESH_ROOT_KEEP=1 (keep the root).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cache="${FRESH_ROOT_CACHE:-/var/cache/fenics-plast-fresh}"
mirror="${FRESH_ROOT_MIRROR:-http://deb.debian.org/debian}"
suite=bookworm

say() { printf 'fresh-root: %s\n' "$*"; }
die() { say "FAILED: $*" >&2; exit 1; }

[ "$(id -u)" -eq 0 ] || die "needs root (debootstrap, mount, chroot)"

# ---- the Dockerfile, read once: the steps the image build runs ----------------------------------
dockerfile="$repo/Dockerfile"
[ -f "$dockerfile" ] || die "no Dockerfile in $repo"
workdir=/
envs=()
runs=()
from=""
# join continuation lines, drop comments and blank lines
while IFS= read -r line; do
    read -r instr rest <<<"$line"
    case "${instr^^}" in
        FROM)    from="$rest" ;;
        WORKDIR) workdir="$rest" ;;
        COPY)    [ "$rest" = ". ." ] || die "Dockerfile: only 'COPY . .' is supported here, found 'COPY $rest'" ;;
        ENV)     envs+=("$rest") ;;
        RUN)     runs+=("$rest") ;;
        CMD)     ;;
        *)       die "Dockerfile: instruction '$instr' is not known to this check; teach scripts/fresh_root_check.sh" ;;
    esac
done < <(sed -e ':a' -e '/\\$/N; s/\\\n//; ta' "$dockerfile" | grep -v -E '^[[:space:]]*(#|$)')
[ "$from" = "debian:bookworm" ] || die "Dockerfile: FROM '$from', this check builds debian:bookworm"
((${#runs[@]})) || die "Dockerfile: no RUN step"
# ENV lines of the form K=V K2=V2 (the form our Dockerfile uses)
env_assign=()
for e in "${envs[@]}"; do
    for kv in $e; do
        [[ "$kv" == *=* ]] || die "Dockerfile: ENV '$e' is not of the form K=V"
        env_assign+=("$kv")
    done
done

# ---- host tools ----------------------------------------------------------------------------------
if ! command -v debootstrap >/dev/null; then
    say "installing debootstrap on the host"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap >/dev/null
fi
mkdir -p "$cache/debootstrap" "$cache/apt-archives/partial"

root="$(mktemp -d "${FRESH_ROOT_TMP:-/var/tmp}/fenics-plast-fresh.XXXXXX")"
mounted=()
cleanup() {
    local rc=$? m ok=1
    for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do
        m="${mounted[i]}"
        umount -R "$m" 2>/dev/null || umount -R -l "$m" 2>/dev/null || { ok=0; say "could not unmount $m" >&2; }
    done
    if [ "${FRESH_ROOT_KEEP:-0}" = 1 ]; then
        say "kept the root at $root"
    elif ((ok)) && ! grep -q " $root/" /proc/mounts; then
        rm -rf --one-file-system "$root"
    else
        say "left $root in place: something is still mounted in it" >&2
    fi
    exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Each step's output goes to $logs/<n>-<step>.log; a failing step prints its last 40 lines.
logs="$cache/logs"
rm -rf "$logs"; mkdir -p "$logs"
step_names=()
step_times=()
step() {   # step NAME COMMAND...: run, time, record; a failure stops the check naming the step
    local name="$1"; shift
    local t0=$SECONDS log
    log="$logs/$((${#step_names[@]} + 1))-${name//[^A-Za-z0-9]/_}.log"
    say "== $name (log: $log)"
    if ! "$@" > "$log" 2>&1; then
        step_names+=("$name"); step_times+=("$((SECONDS - t0)) s  FAILED")
        tail -n 40 "$log" | sed 's/^/    | /' >&2
        report
        die "step '$name' failed (whole log: $log)"
    fi
    step_names+=("$name"); step_times+=("$((SECONDS - t0)) s")
}
report() {
    say "step times:"
    for i in "${!step_names[@]}"; do printf '  %-24s %s\n' "${step_names[i]}" "${step_times[i]}"; done
}

in_root() {   # in_root COMMAND: bash -c COMMAND in the root, in the Dockerfile's WORKDIR, with its ENV
    chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb LANG=C.UTF-8 \
        PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
        "${env_assign[@]}" /bin/bash -c "cd '$workdir' && $1"
}

bootstrap() {
    debootstrap --variant=minbase --cache-dir="$cache/debootstrap" "$suite" "$root" "$mirror" || return 1
    # the apt sources of the debian:bookworm image
    rm -f "$root/etc/apt/sources.list"
    cat > "$root/etc/apt/sources.list.d/debian.sources" <<EOF
Types: deb
URIs: $mirror
Suites: $suite $suite-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: ${mirror%/debian}/debian-security
Suites: $suite-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
    [ $? -eq 0 ] || return 1
    cp -L /etc/resolv.conf "$root/etc/resolv.conf" || return 1
}

# (functions run by `step` are in an `if`, where bash ignores set -e: every command says `|| return 1`)
mount_all() {
    mount -t proc proc "$root/proc" || return 1
    mounted+=("$root/proc")
    mount --rbind /sys "$root/sys" || return 1
    mounted+=("$root/sys")
    mount --make-rslave "$root/sys" || return 1
    mount --rbind /dev "$root/dev" || return 1
    mounted+=("$root/dev")
    mount --make-rslave "$root/dev" || return 1
    # reuse downloaded .deb files between runs (the root itself is new)
    mount --bind "$cache/apt-archives" "$root/var/cache/apt/archives" || return 1
    mounted+=("$root/var/cache/apt/archives")
}

copy_checkout() {
    mkdir -p "$root$workdir" || return 1
    (cd "$repo" && git ls-files -z --cached | xargs -0 -r tar -cf - --no-recursion) \
        | tar -xf - -C "$root$workdir" || return 1
    [ -f "$root$workdir/Makefile" ] || return 1
}

dockerfile_runs() {
    local r
    for r in "${runs[@]}"; do
        say "RUN $r"
        in_root "$r" || return 1
    done
}

say "root $root (Dockerfile: WORKDIR $workdir, ${#runs[@]} RUN step(s))"
step "debootstrap minbase" bootstrap
step "mount /proc /sys /dev" mount_all
step "copy checkout" copy_checkout
step "Dockerfile RUN steps" dockerfile_runs
step "make demo" in_root "make demo"
step "make test" in_root "make test"
tail -n 3 "$logs/$((${#step_names[@]}))-make_test.log" | sed 's/^/    | /'
report
say "passed: the README's two commands work on a fresh minimal bookworm root"
