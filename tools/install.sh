#!/usr/bin/env bash
# Install helixd as a systemd service on the rover's companion computer (run as root).
#
#   sudo tools/install.sh             # install / upgrade in place (idempotent)
#   tools/install.sh --dry-run        # print what it would do, change nothing
#   tools/install.sh --root /tmp/img  # stage into another root (image building, tests)
#
# What it does (each step is skipped when already done):
#   1. system user+group `helixd` (member of dialout)   systemd-sysusers, else useradd
#   2. /opt/helixd/venv with helixd pip-installed from this checkout
#   3. /etc/helixd/helixd.yaml and /etc/helixd/missions/*.yaml from config/ — an existing,
#      edited file is never overwritten: the new version is written next to it as *.new.
#      Its link.url is the autopilot's serial device: --link URL, else the one device in
#      /dev/serial/by-id/ named like an autopilot (ArduPilot, Pixhawk, Cube…), else asked
#      for on a terminal; with none, the config's udpin:0.0.0.0:14550 stays and it says so
#   4. /var/lib/helixd/runs (flight records)             systemd-tmpfiles, else install -d
#   5. /etc/systemd/system/helixd@.service and helixd.service, then `systemctl daemon-reload`
# Then: systemctl enable --now helixd    (helixd serve: all day, started from the radio/GCS)
#   or: systemctl start helixd@square   (flies /etc/helixd/missions/square.yaml once)
set -euo pipefail

usage() {
    cat <<'EOF'
usage: install.sh [--dry-run] [--root DIR] [--no-venv] [--link URL] [-h|--help]
  --dry-run       print the actions, change nothing
  --link URL      the autopilot's link for /etc/helixd/helixd.yaml's link.url, e.g.
                  /dev/serial/by-id/usb-ArduPilot_…-if00 or /dev/serial0:921600 (default:
                  the one autopilot found in /dev/serial/by-id/, else asked on a terminal)
  --root DIR      install below DIR instead of / (alias --prefix; default $DESTDIR or /);
                  users are created in DIR/etc/passwd (systemd-sysusers --root), never on the
                  host, and systemctl is not called
  --no-venv       skip creating /opt/helixd/venv and pip-installing helixd
environment: PYTHON (default python3) builds the venv
EOF
}

REPO_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ROOT="${DESTDIR:-/}"
DRY_RUN=0
WITH_VENV=1
PYTHON="${PYTHON:-python3}"
LINK_URL=""
DEFAULT_LINK_URL="udpin:0.0.0.0:14550"  # config/helixd.yaml's link.url
# /dev/serial/by-id/ names of autopilot boards (ArduPilot's USB names its board; older
# bootloaders say PX4/Pixhawk; CubePilot, Holybro, mRo, CUAV boards)
AUTOPILOT_NAMES='ardupilot|pixhawk|px4|cubepilot|cube|holybro|mro|cuav|fmu'

while [[ $# -gt 0 ]]; do
    case "$1" in
        --dry-run) DRY_RUN=1 ;;
        --root | --prefix)
            [[ $# -ge 2 ]] || { echo "install.sh: $1 needs a directory" >&2; exit 2; }
            ROOT="$2"
            shift
            ;;
        --root=* | --prefix=*) ROOT="${1#*=}" ;;
        --no-venv) WITH_VENV=0 ;;
        --link)
            [[ $# -ge 2 ]] || { echo "install.sh: --link needs a URL" >&2; exit 2; }
            LINK_URL="$2"
            shift
            ;;
        --link=*) LINK_URL="${1#*=}" ;;
        -h | --help) usage; exit 0 ;;
        *) echo "install.sh: unknown option: $1" >&2; usage >&2; exit 2 ;;
    esac
    shift
done

# "" means the real root; every path below is written "$ROOT/etc/...".
[[ "$ROOT" == /* ]] || ROOT="$PWD/$ROOT"
ROOT="${ROOT%/}"

IS_ROOT=0
[[ "$(id -u)" -ne 0 ]] || IS_ROOT=1

SERVICE_USER=helixd
VENV_DIR=/opt/helixd/venv
SHARE_DIR=/opt/helixd/share
ETC_DIR=/etc/helixd
STATE_DIR=/var/lib/helixd
UNIT_DIR=/etc/systemd/system
SYSUSERS_CONF=/etc/sysusers.d/helixd.conf
TMPFILES_CONF=/etc/tmpfiles.d/helixd.conf

say() { printf 'install.sh: %s\n' "$*"; }

# Run a command that changes the system, or only print it under --dry-run.
run() {
    if [[ "$DRY_RUN" -eq 1 ]]; then
        printf '+'
        printf ' %q' "$@"
        printf '\n'
    else
        "$@"
    fi
}

# Same as run, for a command that reads a file on stdin.
run_stdin() {
    local input="$1"
    shift
    if [[ "$DRY_RUN" -eq 1 ]]; then
        printf '+'
        printf ' %q' "$@"
        printf ' < %q\n' "$input"
    else
        "$@" <"$input"
    fi
}

have() { command -v "$1" >/dev/null 2>&1; }

# systemd tools take --root=DIR for a staging root and nothing for the real one.
root_opt=()

# Numeric id of a group in the target root ("" when it does not exist there).
group_id() {
    if [[ -z "$ROOT" ]]; then
        getent group "$1" | cut -d: -f3 || true
    elif [[ -f "$ROOT/etc/group" ]]; then
        awk -F: -v name="$1" '$1 == name { print $3 }' "$ROOT/etc/group"
    fi
}

# chown to root:<service group> when that group exists in the target root.
chown_root_service_group() {
    local gid
    gid="$(group_id "$SERVICE_USER")"
    if [[ -z "$ROOT" ]]; then
        run chown "root:$SERVICE_USER" "$@"
    elif [[ "$IS_ROOT" -eq 0 ]]; then
        say "not root: leaving $* owned by $(id -un)"
    elif [[ -n "$gid" ]]; then
        run chown "0:$gid" "$@"
    elif [[ "$DRY_RUN" -eq 1 ]]; then
        run chown "0:$SERVICE_USER" "$@"
    else
        say "warning: group $SERVICE_USER not found in ${ROOT:-/}; leaving $* owned by root"
    fi
}

# Copy a file the admin may edit: never overwrite a changed copy, write <dest>.new instead.
install_config_file() {
    local src="$1" dest="$ROOT$2"
    if [[ ! -e "$dest" ]]; then
        say "installing $2"
        run install -m 0640 "$src" "$dest"
        chown_root_service_group "$dest"
    elif cmp -s "$src" "$dest"; then
        say "unchanged $2"
    elif [[ -e "$dest.new" ]] && cmp -s "$src" "$dest.new"; then
        say "kept edited $2 (new default already in $2.new)"
    else
        say "kept edited $2; new default written to $2.new — merge by hand"
        run install -m 0640 "$src" "$dest.new"
        chown_root_service_group "$dest.new"
    fi
}

# Copy a file helixd owns (unit, sysusers, tmpfiles, docs): replaced when it differs.
# Sets CHANGED=1 when it (would have) installed the file. (Not a return code: a function
# run under `||`/`&&` loses set -e, and a failed install must stop the script.)
CHANGED=0
install_owned_file() {
    local src="$1" dest="$ROOT$2" mode="$3"
    CHANGED=0
    if [[ -e "$dest" ]] && cmp -s "$src" "$dest"; then
        say "unchanged $2"
        return
    fi
    say "installing $2"
    run install -D -m "$mode" "$src" "$dest"
    CHANGED=1
}

step_user() {
    install_owned_file "$REPO_DIR/systemd/helixd.sysusers.conf" "$SYSUSERS_CONF" 0644
    if [[ -n "$ROOT" && "$IS_ROOT" -eq 0 ]]; then
        say "not root: user $SERVICE_USER not created in $ROOT" \
            "(systemd-sysusers.service creates it from $SYSUSERS_CONF at first boot)"
    elif have systemd-sysusers; then
        # The config comes on stdin so the same command works for / and for --root.
        say "creating user $SERVICE_USER in ${ROOT:-}/etc/passwd (systemd-sysusers)"
        [[ -z "$ROOT" ]] || run mkdir -p "$ROOT/etc"
        run_stdin "$REPO_DIR/systemd/helixd.sysusers.conf" \
            systemd-sysusers "${root_opt[@]}" -
    elif [[ -n "$ROOT" ]]; then
        say "systemd-sysusers not found: user $SERVICE_USER not created in $ROOT" \
            "(systemd-sysusers.service creates it from $SYSUSERS_CONF at first boot)"
    else
        if getent group "$SERVICE_USER" >/dev/null; then
            say "group $SERVICE_USER exists"
        else
            run groupadd --system "$SERVICE_USER"
        fi
        if getent passwd "$SERVICE_USER" >/dev/null; then
            say "user $SERVICE_USER exists"
        else
            run useradd --system --gid "$SERVICE_USER" --home-dir "$STATE_DIR" --no-create-home \
                --shell /usr/sbin/nologin --comment "helixd rover daemon" "$SERVICE_USER"
        fi
        if getent group dialout >/dev/null; then
            say "group dialout exists"
        else
            run groupadd --system dialout
        fi
        if id -nG "$SERVICE_USER" 2>/dev/null | tr ' ' '\n' | grep -qx dialout; then
            say "user $SERVICE_USER is in dialout"
        else
            run usermod --append --groups dialout "$SERVICE_USER"
        fi
    fi
}

step_venv() {
    if [[ "$WITH_VENV" -eq 0 ]]; then
        say "skipping $VENV_DIR (--no-venv)"
        return
    fi
    if [[ -x "$ROOT$VENV_DIR/bin/python" ]]; then
        say "venv $VENV_DIR exists"
    else
        say "creating venv $VENV_DIR"
        run "$PYTHON" -m venv "$ROOT$VENV_DIR"
    fi
    say "pip-installing helixd from $REPO_DIR into $VENV_DIR"
    if [[ "$DRY_RUN" -eq 1 ]]; then
        run "$ROOT$VENV_DIR/bin/python" -m pip install --quiet --upgrade "$REPO_DIR"
        return
    fi
    # Build from a copy: pip builds in-tree, and a root-owned build/ in the checkout would
    # get in the developer's way.
    local src
    src="$(mktemp -d)"
    # shellcheck disable=SC2064  # expand $src now: it is local to this function
    trap "rm -rf '$src'" EXIT
    local item
    for item in pyproject.toml README.md LICENSE helixd; do
        [[ ! -e "$REPO_DIR/$item" ]] || cp -R "$REPO_DIR/$item" "$src/"
    done
    find "$src" -name __pycache__ -prune -exec rm -rf {} +
    "$ROOT$VENV_DIR/bin/python" -m pip install --quiet --upgrade "$src"
    rm -rf "$src"
    trap - EXIT
}

# The autopilot's serial devices in the target root's /dev/serial/by-id/ (MAVLink is on a
# board's first interface, -if00; its second, SLCAN, is left out).
autopilot_devices() {
    local dir="$ROOT/dev/serial/by-id" dev name
    [[ -d "$dir" ]] || return 0
    for dev in "$dir"/*; do
        [[ -e "$dev" || -L "$dev" ]] || continue
        name="$(basename "$dev")"
        if printf '%s\n' "$name" | grep -Eiq "$AUTOPILOT_NAMES" \
            && ! printf '%s\n' "$name" | grep -Eq -- '-if0[1-9]$'; then
            printf '%s\n' "/dev/serial/by-id/$name"
        fi
    done
}

# LINK_URL: given, found, or asked for; "" keeps the config's default.
choose_link() {
    [[ -z "$LINK_URL" ]] || { say "link.url: $LINK_URL (--link)"; return; }
    local found=()
    mapfile -t found < <(autopilot_devices)
    if [[ "${#found[@]}" -eq 1 ]]; then
        LINK_URL="${found[0]}"
        say "link.url: $LINK_URL (the autopilot found in /dev/serial/by-id/)"
        return
    fi
    if [[ "${#found[@]}" -gt 1 ]]; then
        say "several autopilot-like devices in /dev/serial/by-id/: ${found[*]}"
    fi
    if [[ "$DRY_RUN" -eq 0 && -t 0 ]]; then
        local prompt="install.sh: the autopilot's serial device (e.g. /dev/ttyACM0,"
        prompt+=" /dev/serial0:921600; empty keeps $DEFAULT_LINK_URL): "
        read -r -p "$prompt" LINK_URL || LINK_URL=""
    fi
    if [[ -z "$LINK_URL" ]]; then
        say "warning: link.url stays $DEFAULT_LINK_URL (listens for UDP, not the autopilot's" \
            "serial port): set link.url in $ETC_DIR/helixd.yaml, or run again with --link URL"
    fi
}

step_config() {
    run install -d -m 0750 "$ROOT$ETC_DIR" "$ROOT$ETC_DIR/missions"
    chown_root_service_group "$ROOT$ETC_DIR" "$ROOT$ETC_DIR/missions"
    choose_link
    local config="$REPO_DIR/config/helixd.yaml"
    if [[ -n "$LINK_URL" ]]; then
        case "$LINK_URL" in
            */* | udp* | tcp*) ;;
            *) echo "install.sh: --link $LINK_URL: not a device path or udp/tcp URL" >&2; exit 2 ;;
        esac
        RENDERED_CONFIG="$(mktemp)"
        # shellcheck disable=SC2064  # expand now
        trap "rm -f '$RENDERED_CONFIG'" EXIT
        awk -v url="$LINK_URL" -v old="$DEFAULT_LINK_URL" '
            /^link:/ { in_link = 1 }
            /^[^ #]/ && !/^link:/ { in_link = 0 }
            in_link && $1 == "url:" && $2 == old { sub(old, url) }
            { print }' "$config" >"$RENDERED_CONFIG"
        config="$RENDERED_CONFIG"
    fi
    install_config_file "$config" "$ETC_DIR/helixd.yaml"
    local mission
    for mission in "$REPO_DIR"/config/missions/*.yaml; do
        [[ -e "$mission" ]] || continue
        install_config_file "$mission" "$ETC_DIR/missions/$(basename "$mission")"
    done
}

step_state_dirs() {
    install_owned_file "$REPO_DIR/systemd/helixd.tmpfiles.conf" "$TMPFILES_CONF" 0644
    local tmpfiles_ok=0
    if have systemd-tmpfiles; then
        if [[ -z "$ROOT" ]]; then
            tmpfiles_ok=1
        elif [[ "$IS_ROOT" -eq 1 && -n "$(group_id "$SERVICE_USER")" ]]; then
            tmpfiles_ok=1
        fi
    fi
    if [[ "$tmpfiles_ok" -eq 1 ]]; then
        say "creating $STATE_DIR/runs (systemd-tmpfiles)"
        run_stdin "$REPO_DIR/systemd/helixd.tmpfiles.conf" \
            systemd-tmpfiles "${root_opt[@]}" --create -
    else
        say "creating $STATE_DIR/runs"
        run install -d -m 0750 "$ROOT$STATE_DIR" "$ROOT$STATE_DIR/runs"
        if [[ -z "$ROOT" ]]; then
            run chown "$SERVICE_USER:$SERVICE_USER" "$STATE_DIR" "$STATE_DIR/runs"
        fi
    fi
}

step_unit() {
    install_owned_file "$REPO_DIR/systemd/README.md" "$SHARE_DIR/README.systemd.md" 0644
    install_owned_file "$REPO_DIR/systemd/helixd@.service" "$UNIT_DIR/helixd@.service" 0644
    local unit_changed="$CHANGED"
    install_owned_file "$REPO_DIR/systemd/helixd.service" "$UNIT_DIR/helixd.service" 0644
    [[ "$unit_changed" -eq 0 ]] || CHANGED=1
    if [[ -n "$ROOT" ]]; then
        say "not calling systemctl (installing into $ROOT)"
    elif [[ ! -d /run/systemd/system ]]; then
        say "systemd is not running here: skipped systemctl daemon-reload"
    elif [[ "$CHANGED" -eq 1 ]]; then
        run systemctl daemon-reload
    else
        say "unit unchanged: no daemon-reload needed"
    fi
}

main() {
    if [[ -z "$ROOT" && "$DRY_RUN" -eq 0 && "$IS_ROOT" -eq 0 ]]; then
        echo "install.sh: must run as root (or use --dry-run / --root DIR)" >&2
        exit 1
    fi
    [[ "$DRY_RUN" -eq 1 ]] && say "dry run: nothing is changed"
    say "installing helixd from $REPO_DIR into ${ROOT:-/}"
    if [[ -n "$ROOT" ]]; then
        root_opt=("--root=$ROOT")
        run mkdir -p "$ROOT"
    fi
    step_user
    step_venv
    step_config
    step_state_dirs
    step_unit
    local url
    url="$(awk '/^link:/ { l = 1; next } /^[^ #]/ { l = 0 } l && $1 == "url:" { print $2; exit }' \
        "$ROOT$ETC_DIR/helixd.yaml" 2>/dev/null || true)"
    say "done. helixd talks to the autopilot on link.url = ${url:-${LINK_URL:-$DEFAULT_LINK_URL}} ($ETC_DIR/helixd.yaml)"
    say "all day, started from the ground station or the radio: systemctl enable --now helixd" \
        "(helixd.service: helixd serve)"
    say "or one mission file once: systemctl start helixd@<mission>" \
        "(mission files in $ETC_DIR/missions)"
}

main
