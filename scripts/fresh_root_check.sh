#!/usr/bin/env bash
# Fresh-root check: do what a new user does on a minimal Debian 12 bookworm and Debian 13 trixie, and
# fail if any step fails.
#
#   bash scripts/fresh_root_check.sh bookworm|trixie   # one suite
#   bash scripts/fresh_root_check.sh                   # both at the same time, then a table
#
# For each suite:
#   1. build a minimal root of that suite with `debootstrap --variant=minbase` (what the
#      debian:<suite> image of our Dockerfile starts from), with that image's apt sources (the suite,
#      <suite>-updates, <suite>-security), on the mirrors this host's own apt uses;
#   2. copy the checkout into it (the files git tracks, as they are in the work tree: a file that was
#      never `git add`ed is missing here as it would be in a clone);
#   3. run in it, with chroot, the Dockerfile's own steps: this script reads the Dockerfile (its ARG
#      DEBIAN_RELEASE set to the suite, as `docker build --build-arg` would) and runs its WORKDIR, ENV
#      and RUN lines (COPY . . is step 2), so the two cannot drift apart;
#   4. run there `make docs` (the user guide, warnings as errors), then the README's two commands: `make demo`,
#      then `make test` (and, with FRESH_ROOT_SLOW=1, the slow tests: `pytest -m slow`).
# With no argument both suites run at the same time, each in its own root (its lines prefixed with
# [suite]); one failing does not stop the other, and the exit status is non-zero if either failed.
#
# /proc, /sys and /dev are mounted in the root and always unmounted (trap), also when a step fails;
# the root is then deleted. Downloaded .deb files are kept between runs in
# $FRESH_ROOT_CACHE/<suite>/ (default /var/cache/fenics-plast-fresh), so a second run downloads
# nothing; the root itself is new every time. Each step's output is in $FRESH_ROOT_CACHE/<suite>/logs/
# (the last run's); a failing step prints its tail.
#
# Mirrors: read from this host's apt sources (deb822 /etc/apt/sources.list.d/*.sources, one-line
# /etc/apt/sources.list and /etc/apt/sources.list.d/*.list): the Debian archive entry, and the
# security entry if the host has one (if not, the root gets no security source).
#
# Needs root (debootstrap, mount, chroot); apt-installs debootstrap on the host if it is missing.
# Environment: FRESH_ROOT_CACHE, FRESH_ROOT_TMP (where the root is made, default /var/tmp),
# FRESH_ROOT_MIRROR and FRESH_ROOT_SECURITY_MIRROR (instead of the host's), FRESH_ROOT_KEEP=1 (keep
# the root), FRESH_ROOT_SLOW=1 (also the slow tests), FRESH_ROOT_EXTRA=COMMAND (one more step in the root
# after the tests, in the checkout, e.g. a test run many times), FRESH_ROOT_DRY_RUN=1 (print the plan: suite,
# mirrors, the Dockerfile's steps; build nothing, needs no root).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cache="${FRESH_ROOT_CACHE:-/var/cache/fenics-plast-fresh}"
dry_run="${FRESH_ROOT_DRY_RUN:-0}"
suites_supported=(bookworm trixie)

say() { printf 'fresh-root: %s\n' "$*"; }
die() { say "FAILED: $*" >&2; exit 1; }
host_tools() {     # debootstrap on the host, apt-installed if missing (once, before the suites start)
    command -v debootstrap >/dev/null && return 0
    say "installing debootstrap on the host"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap >/dev/null
}

# ---- the host's apt sources ----------------------------------------------------------------------
# apt_entries ETC_APT: one line per source entry, in apt's reading order:
#   file|types|first URI|suites|components|signed-by|enabled
apt_entries() {
    local etc="$1" f
    local files=() parts=()
    # apt reads sources.list, then sources.list.d/ in name order (only *.list and *.sources)
    [ -f "$etc/sources.list" ] && files+=("$etc/sources.list")
    for f in "$etc"/sources.list.d/*.list "$etc"/sources.list.d/*.sources; do
        [ -f "$f" ] && parts+=("$f")
    done
    ((${#parts[@]})) && mapfile -t -O "${#files[@]}" files < <(printf '%s\n' "${parts[@]}" | LC_ALL=C sort)
    for f in "${files[@]}"; do
        case "$f" in
        *.sources)   # deb822 stanzas; '#' lines are comments, indented lines continue a field
            awk -v file="$f" '
                function flush() {
                    if (n) print file "|" types "|" uri "|" suites "|" comps "|" signed "|" enabled
                    n = 0; types = uri = suites = comps = signed = last = ""; enabled = "yes"
                }
                BEGIN { enabled = "yes" }
                /^#/ { next }
                /^[ \t]*$/ { flush(); next }
                /^[ \t]/ {   # continuation: more words, or an inline key (Signed-By)
                    v = $0; gsub(/^[ \t]+|[ \t]+$/, "", v)
                    if (last == "types") types = types " " v
                    else if (last == "suites") suites = suites " " v
                    else if (last == "components") comps = comps " " v
                    else if (last == "uris" && uri == "") uri = v
                    next
                }
                {
                    i = index($0, ":"); if (!i) next
                    key = tolower(substr($0, 1, i - 1)); v = substr($0, i + 1)
                    gsub(/^[ \t]+|[ \t]+$/, "", v); n = 1; last = key
                    if (key == "types") types = v
                    else if (key == "uris") { split(v, w, /[ \t]+/); uri = w[1] }
                    else if (key == "suites") suites = v
                    else if (key == "components") comps = v
                    else if (key == "signed-by") signed = (v == "" ? "(inline key)" : v)
                    else if (key == "enabled") enabled = tolower(v)
                }
                END { flush() }' "$f" ;;
        *)           # one-line: deb [options] URI SUITE COMPONENT...
            awk -v file="$f" '
                { sub(/#.*/, "") }
                $1 != "deb" && $1 != "deb-src" { next }
                {
                    type = $1; rest = $0; sub(/^[ \t]*deb(-src)?[ \t]+/, "", rest); signed = ""
                    if (rest ~ /^\[/) {
                        opts = substr(rest, 2, index(rest, "]") - 2); rest = substr(rest, index(rest, "]") + 1)
                        nopt = split(opts, o, /[ \t]+/)
                        for (k = 1; k <= nopt; k++) if (tolower(o[k]) ~ /^signed-by=/) signed = substr(o[k], 11)
                    }
                    nw = split(rest, w, /[ \t]+/); j = (w[1] == "" ? 2 : 1)
                    comps = ""; for (k = j + 2; k <= nw; k++) comps = comps (comps == "" ? "" : " ") w[k]
                    print file "|" type "|" w[j] "|" w[j + 1] "|" comps "|" signed "|yes"
                }' "$f" ;;
        esac
    done
}

# usable_uri URI: the URI debootstrap and the root's apt can use (http, https, file; a mirror+file:
# list gives its first mirror), or nothing
usable_uri() {
    local u="$1"
    if [[ "$u" == mirror+file:* ]]; then
        u="${u#mirror+file:}"; u="/${u#"${u%%[!/]*}"}"   # mirror+file:/x and mirror+file:///x
        [ -r "$u" ] || return 0
        u="$(grep -v -E '^[[:space:]]*(#|$)' "$u" | head -n 1 | awk '{print $1}')"
    fi
    case "$u" in http://* | https://* | file:/*) printf '%s\n' "${u%/}" ;; esac
}

# host_mirrors [ETC_APT [OS_RELEASE]]: sets host_archive / host_security (URI, or empty) and
# host_archive_from / host_security_from (the file each came from). The archive entry: a deb entry
# with component main, one of whose suites is the host's codename or a Debian suite name (not
# -security), signed by debian-archive-keyring or with a URI ending in /debian. The security entry:
# a deb entry with component main and a suite <Debian suite>-security. Third-party sources match
# neither.
host_mirrors() {
    local etc="${1:-/etc/apt}" osr="${2:-/etc/os-release}" codename="" names
    local file types uri suites comps signed enabled s u
    [ -r "$osr" ] && codename="$(sed -n 's/^VERSION_CODENAME=//p' "$osr" | tr -d '"'\''')"
    names=" $codename buster bullseye bookworm trixie forky duke sid stable testing unstable oldstable oldoldstable "
    host_archive="" host_archive_from="" host_security="" host_security_from=""
    while IFS='|' read -r file types uri suites comps signed enabled; do
        [ "$enabled" != no ] || continue
        [[ " $types " == *" deb "* && " $comps " == *" main "* ]] || continue
        u="$(usable_uri "$uri")"
        [ -n "$u" ] || continue
        for s in $suites; do
            if [[ "$s" == *-security ]]; then
                if [ -z "$host_security" ] && [[ "$names" == *" ${s%-security} "* ]]; then
                    host_security="$u" host_security_from="$file"
                fi
            elif [ -z "$host_archive" ] && [[ "$names" == *" $s "* ]] \
                 && [[ "$signed" == *debian-archive-keyring* || "$u" == */debian ]]; then
                host_archive="$u" host_archive_from="$file"
            fi
        done
    done < <(apt_entries "$etc")
}

# ---- the Dockerfile: the steps the image build runs ----------------------------------------------
# read_dockerfile SUITE: sets from, workdir, envs, runs, env_assign; ARG lines before FROM are
# build arguments for FROM, DEBIAN_RELEASE set to SUITE (as `docker build --build-arg` would).
read_dockerfile() {
    local suite="$1" dockerfile="$repo/Dockerfile" line instr rest name value
    local -A args=()
    [ -f "$dockerfile" ] || die "no Dockerfile in $repo"
    workdir=/ envs=() runs=() from="" from_raw="" env_assign=()
    # join continuation lines, drop comments and blank lines
    while IFS= read -r line; do
        read -r instr rest <<<"$line"
        case "${instr^^}" in
            ARG)
                [ -z "$from_raw" ] || die "Dockerfile: ARG after FROM is not known to this check; teach scripts/fresh_root_check.sh"
                name="${rest%%=*}"; value=""
                [[ "$rest" == *=* ]] && { value="${rest#*=}"; value="${value#\"}"; value="${value%\"}"; }
                [[ "$name" =~ ^[A-Za-z_][A-Za-z0-9_]*$ ]] || die "Dockerfile: ARG '$rest' is not of the form NAME=default"
                args[$name]="$value" ;;
            FROM)
                [ -z "$from_raw" ] || die "Dockerfile: a second FROM ('$rest'): multi-stage builds are not known to this check"
                from_raw="$rest" ;;
            WORKDIR) workdir="$rest" ;;
            COPY)    [ "$rest" = ". ." ] || die "Dockerfile: only 'COPY . .' is supported here, found 'COPY $rest'" ;;
            ENV)     envs+=("$rest") ;;
            RUN)     runs+=("$rest") ;;
            CMD)     ;;
            *)       die "Dockerfile: instruction '$instr' is not known to this check; teach scripts/fresh_root_check.sh" ;;
        esac
    done < <(sed -e ':a' -e '/\\$/N; s/\\\n//; ta' "$dockerfile" | grep -v -E '^[[:space:]]*(#|$)')
    [ -n "$from_raw" ] || die "Dockerfile: no FROM"
    [ -z "${args[DEBIAN_RELEASE]+set}" ] || args[DEBIAN_RELEASE]="$suite"
    from="$from_raw"
    for name in "${!args[@]}"; do
        from="${from//\$\{$name\}/${args[$name]}}"
        from="${from//\$$name/${args[$name]}}"
    done
    [[ "$from" != *\$* ]] || die "Dockerfile: FROM '$from_raw' uses a build argument no ARG line before it declares (or a form this check does not know)"
    [ "$from" = "debian:$suite" ] || die "Dockerfile: FROM '$from_raw' gives '$from', but this check builds debian:$suite (write 'ARG DEBIAN_RELEASE=...' and 'FROM debian:\${DEBIAN_RELEASE}')"
    ((${#runs[@]})) || die "Dockerfile: no RUN step"
    # ENV lines of the form K=V K2=V2 (the form our Dockerfile uses)
    local e kv
    for e in "${envs[@]}"; do
        for kv in $e; do
            [[ "$kv" == *=* ]] || die "Dockerfile: ENV '$e' is not of the form K=V"
            env_assign+=("$kv")
        done
    done
}

# root_sources KEYRING: the root's deb822 apt sources, those of the debian:<suite> image
root_sources() {
    printf 'Types: deb\nURIs: %s\nSuites: %s %s-updates\nComponents: main\nSigned-By: %s\n' \
        "$mirror" "$suite" "$suite" "$1"
    if [ -n "$security" ]; then
        printf '\nTypes: deb\nURIs: %s\nSuites: %s-security\nComponents: main\nSigned-By: %s\n' \
            "$security" "$suite" "$1"
    fi
}

# (`source` this file to use the functions above alone, e.g. to test host_mirrors)
[[ "${BASH_SOURCE[0]}" == "$0" ]] || return 0

usage="usage: bash scripts/fresh_root_check.sh [$(IFS='|'; echo "${suites_supported[*]}")]  (no argument: both)"
# ---- no argument: every suite at the same time, each its own run (and root), then a table -------
if (($# == 0)); then
    [ "$dry_run" = 1 ] || [ "$(id -u)" -eq 0 ] || die "needs root (debootstrap, mount, chroot)"
    rc=0 results=() pids=()
    if [ "$dry_run" = 1 ]; then
        for s in "${suites_supported[@]}"; do
            say "======== $s"
            bash "${BASH_SOURCE[0]}" "$s" || rc=1
        done
        exit "$rc"
    fi
    # The suites run at the same time, each in its own root: most of a suite's time is one process
    # (the JIT compiler, pytest), so on two cores this halves the check. Each line is prefixed with
    # its suite.
    # debootstrap first, once: two suites installing it at the same time collide on apt's lock (one fails)
    host_tools
    trap 'kill "${pids[@]}" 2>/dev/null; wait; exit 130' INT TERM   # Ctrl-C stops both suites
    for s in "${suites_supported[@]}"; do
        rm -f "$cache/$s/logs/times"
        bash "${BASH_SOURCE[0]}" "$s" 2>&1 | sed -u "s/^/[$s] /" &
        pids+=($!)
    done
    for pid in "${pids[@]}"; do
        if wait "$pid"; then results+=(passed); else results+=(FAILED); rc=1; fi
    done
    # the table: one row per step (in the order they ran), one column per suite
    declare -A cell=() seen=()
    rows=()
    for s in "${suites_supported[@]}"; do
        [ -f "$cache/$s/logs/times" ] || continue
        while IFS='|' read -r name secs status; do
            [ -n "${seen[$name]:-}" ] || { seen[$name]=1; rows+=("$name"); }
            cell[$s|$name]="$secs s${status:+ $status}"
        done < "$cache/$s/logs/times"
    done
    say "step times, each suite on its own fresh root:"
    printf '  %-24s' step; printf ' %-14s' "${suites_supported[@]}"; echo
    for name in "${rows[@]}"; do
        printf '  %-24s' "$name"
        for s in "${suites_supported[@]}"; do printf ' %-14s' "${cell[$s|$name]:--}"; done; echo
    done
    printf '  %-24s' result; printf ' %-14s' "${results[@]}"; echo
    ((rc == 0)) && say "passed: the README's two commands work on fresh minimal bookworm and trixie roots"
    exit "$rc"
fi
(($# == 1)) || die "$usage"
suite="$1"
[[ " ${suites_supported[*]} " == *" $suite "* ]] || die "unknown suite '$suite'; $usage"

read_dockerfile "$suite"

# ---- the mirrors ---------------------------------------------------------------------------------
host_mirrors /etc/apt /etc/os-release
mirror="${FRESH_ROOT_MIRROR:-$host_archive}" mirror_from="${FRESH_ROOT_MIRROR:+FRESH_ROOT_MIRROR}"
security="${FRESH_ROOT_SECURITY_MIRROR:-$host_security}"
security_from="${FRESH_ROOT_SECURITY_MIRROR:+FRESH_ROOT_SECURITY_MIRROR}"
mirror="${mirror%/}" security="${security%/}"
[ -n "$mirror" ] || die "no Debian archive found in this host's apt sources" \
    "(/etc/apt/sources.list, /etc/apt/sources.list.d/*.list, *.sources);" \
    "set FRESH_ROOT_MIRROR to a Debian mirror's URL (and FRESH_ROOT_SECURITY_MIRROR to its security archive's)"
mirror_from="${mirror_from:-$host_archive_from}" security_from="${security_from:-$host_security_from}"
security_line="$security (from $security_from)"
[ -n "$security" ] || security_line="none found in this host's apt sources: the root gets no $suite-security source"

if [ "$dry_run" = 1 ]; then
    say "plan for $suite (FRESH_ROOT_DRY_RUN=1: nothing is built)"
    printf '  %-16s %s\n' suite "$suite (Dockerfile: FROM $from_raw -> $from)" \
        mirror "$mirror (from $mirror_from)" "security mirror" "$security_line" \
        WORKDIR "$workdir" ENV "${env_assign[*]}"
    for i in "${!runs[@]}"; do printf '  %-16s %s\n' "RUN $((i + 1))" "${runs[i]}"; done
    printf '  %-16s %s\n' "then" "make docs; make demo; make test" \
        cache "$cache/$suite/{apt-archives,debootstrap,logs}" "root's sources" "/etc/apt/sources.list.d/debian.sources:"
    root_sources "/usr/share/keyrings/debian-archive-keyring.(pgp|gpg: the one the root has)" | sed 's/^/      | /'
    exit 0
fi

[ "$(id -u)" -eq 0 ] || die "needs root (debootstrap, mount, chroot)"

# ---- host tools ----------------------------------------------------------------------------------
host_tools
# the cache was one folder before there were two suites (bookworm's): move it once
if [ -d "$cache/apt-archives" ] && [ ! -e "$cache/bookworm" ]; then
    mkdir -p "$cache/bookworm"
    mv "$cache/apt-archives" "$cache/bookworm/"
    [ ! -d "$cache/debootstrap" ] || mv "$cache/debootstrap" "$cache/bookworm/"
    rm -rf "$cache/logs"
fi
scache="$cache/$suite"
mkdir -p "$scache/debootstrap" "$scache/apt-archives/partial"

root="$(mktemp -d "${FRESH_ROOT_TMP:-/var/tmp}/fenics-plast-fresh-$suite.XXXXXX")"
chmod 755 "$root"   # mktemp makes it 0700; apt in the root drops to its _apt user, who must get in
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
# $logs/times: one line per step, NAME|SECONDS|FAILED-or-nothing (the table of a two-suite run).
logs="$scache/logs"
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
        echo "$name|$((SECONDS - t0))|FAILED" >> "$logs/times"
        tail -n 40 "$log" | sed 's/^/    | /' >&2
        report
        die "$suite: step '$name' failed (whole log: $log)"
    fi
    step_names+=("$name"); step_times+=("$((SECONDS - t0)) s")
    echo "$name|$((SECONDS - t0))|" >> "$logs/times"
}
report() {
    say "$suite: step times:"
    for i in "${!step_names[@]}"; do printf '  %-24s %s\n' "${step_names[i]}" "${step_times[i]}"; done
}

in_root() {   # in_root COMMAND: bash -c COMMAND in the root, in the Dockerfile's WORKDIR, with its ENV
    chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb LANG=C.UTF-8 \
        PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
        "${env_assign[@]}" /bin/bash -c "cd '$workdir' && $1"
}

# (functions run by `step` are in an `if`, where bash ignores set -e: every command says `|| return 1`)
bootstrap() {
    local keyring
    debootstrap --variant=minbase --cache-dir="$scache/debootstrap" "$suite" "$root" "$mirror" || return 1
    # the apt sources of the debian:<suite> image, signed by the keyring file the root has
    for keyring in /usr/share/keyrings/debian-archive-keyring.{pgp,gpg} ""; do
        [ -z "$keyring" ] || [ ! -f "$root$keyring" ] || break
    done
    [ -n "$keyring" ] || { echo "no debian-archive-keyring in the root"; return 1; }
    rm -f "$root/etc/apt/sources.list"
    root_sources "$keyring" > "$root/etc/apt/sources.list.d/debian.sources" || return 1
    cat "$root/etc/apt/sources.list.d/debian.sources"
    cp -L /etc/resolv.conf "$root/etc/resolv.conf" || return 1
    # /etc/hosts as a container (and Debian's installer) has it: localhost and this machine's name.
    # debootstrap writes none, and without it Open MPI's start-up looks the host name up in DNS: every
    # MPI process (each CLI run of the tests) then waited 5 s for a resolver timeout on bookworm.
    printf '127.0.0.1\tlocalhost\n::1\tlocalhost ip6-localhost ip6-loopback\n127.0.1.1\t%s\n' \
        "$(hostname)" > "$root/etc/hosts" || return 1
}

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
    mount --bind "$scache/apt-archives" "$root/var/cache/apt/archives" || return 1
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

say "$suite: root $root (Dockerfile: FROM $from, WORKDIR $workdir, ${#runs[@]} RUN step(s))"
say "$suite: mirror $mirror (from $mirror_from); security: $security_line"
step "debootstrap minbase" bootstrap
step "mount /proc /sys /dev" mount_all
step "copy checkout" copy_checkout
step "Dockerfile RUN steps" dockerfile_runs
step "make docs" in_root "make docs"
step "make demo" in_root "make demo"
step "make test" in_root "make test"
tail -n 3 "$logs/$((${#step_names[@]}))-make_test.log" | sed 's/^/    | /'
if [ "${FRESH_ROOT_SLOW:-0}" = 1 ]; then
    step "slow tests" in_root ".venv/bin/python -m pytest -q -m slow tests"
    tail -n 3 "$logs/$((${#step_names[@]}))-slow_tests.log" | sed 's/^/    | /'
fi
if [ -n "${FRESH_ROOT_EXTRA:-}" ]; then
    step "extra: $FRESH_ROOT_EXTRA" in_root "$FRESH_ROOT_EXTRA"
    tail -n 12 "$logs/$((${#step_names[@]}))-"*extra*.log | sed 's/^/    | /'
fi
report
say "passed: the README's two commands work on a fresh minimal $suite root"
