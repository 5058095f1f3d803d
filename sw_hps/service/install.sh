#!/bin/sh
# Install (or redeploy) the stereogest board bundle on the board; POSIX sh, for
# BusyBox as for Debian. `make deploy` runs it through ssh; the bundle ships
# it as install.sh (the source is sw_hps/service/install.sh).
#
#   sh install.sh [--service] [--init systemd|sysv] [--bus devmem|uio] TARBALL [DIR]
#       Unpack TARBALL into a fresh directory beside DIR (default: stereogest,
#       relative to the current directory), then swap it in by renaming: the
#       previous tree becomes DIR.old and is removed, so a module deleted from
#       the bundle and the previous tree's __pycache__ never survive.
#   sh DIR/install.sh --service [--init systemd|sysv] [--bus devmem|uio]
#       Only install the service for the tree holding this script.
#
# --service (root) creates the system user stereogest (groups stereogest and
# dialout) the application runs as, installs the systemd unit
# /etc/systemd/system/stereogest.service (or, without systemd or with --init
# sysv, /etc/init.d/stereogest) for DIR, the udev rule that gives the uio device
# to that user (/etc/udev/rules.d/60-stereogest.rules) and /etc/default/stereogest
# (the application's arguments) unless it exists; then prints how to enable it.
# --bus sets the bus in /etc/default/stereogest (devmem: /dev/mem, as root until
# the page is mapped, through the drop-in stereogest.service.d/devmem.conf; uio:
# /dev/stereogest, never root); without it the bus already there is kept
# (devmem for a new file). DESTDIR=/some/root writes under that root instead
# (no root needed, no user created, no systemctl or udevadm call): for
# packaging and tests.
# Exit status: 0 done, 1 a step failed (that step changed nothing), 2 bad usage.

NAME=stereogest
PROG=install.sh
# The system user the application runs as (also in stereogest.service,
# stereogest-devmem.conf, stereogest.init and 60-stereogest.rules).
USER_NAME=stereogest

die() {
    echo "$PROG: error: $*" >&2
    exit 1
}

usage_error() {
    echo "$PROG: error: $*" >&2
    echo "usage: sh install.sh [--service] [--init systemd|sysv] [--bus devmem|uio] TARBALL" \
        "[DIR] | sh DIR/install.sh --service [--init systemd|sysv] [--bus devmem|uio]" >&2
    exit 2
}

# Fill in the install directory and the interpreter; written through a
# temporary file, so the target is never half-written.
install_substituted() {  # SOURCE TARGET MODE
    sed -e "s|@DIR@|$dir|g" -e "s|@PYTHON@|$python|g" "$1" >"$2.tmp" &&
        chmod "$3" "$2.tmp" && mv "$2.tmp" "$2" || {
        rm -f "$2.tmp"
        die "cannot write $2"
    }
}

# The file's STEREOGEST_BUS as devmem, uio or sim (empty if it names none).
bus_of() {  # SETTINGS-FILE
    value=$(. "$1" >/dev/null 2>&1; printf '%s' "$STEREOGEST_BUS")
    case " $value " in
        *" --bus uio "* | *" --bus=uio "*) echo uio ;;
        *" --bus devmem "* | *" --bus=devmem "*) echo devmem ;;
        *" --bus sim "* | *" --bus=sim "*) echo sim ;;
    esac
}

bus_setting() {  # devmem|uio
    if [ "$1" = uio ]; then
        echo 'STEREOGEST_BUS="--bus uio --uio /dev/stereogest"'
    else
        echo 'STEREOGEST_BUS="--bus devmem"'
    fi
}

# The settings file with STEREOGEST_BUS set for $bus, written through a
# temporary file. An existing file keeps every other line.
write_settings() {  # SOURCE TARGET
    line=$(bus_setting "$bus")
    if grep -q '^STEREOGEST_BUS=' "$1"; then
        sed -e "s|^STEREOGEST_BUS=.*|$line|" "$1" >"$2.tmp"
    else
        { cat "$1" && echo "$line"; } >"$2.tmp"
    fi && chmod 644 "$2.tmp" && mv "$2.tmp" "$2" || {
        rm -f "$2.tmp"
        die "cannot write /etc/default/$NAME"
    }
}

# The system user, its own group (the uio device's, by the udev rule) and
# dialout (the robot's tty), with useradd (Debian) or BusyBox's adduser.
ensure_user() {
    if [ -n "$DESTDIR" ]; then
        echo "$PROG: DESTDIR: the system user $USER_NAME is not created here;" \
            "the target system needs it (install.sh --service there creates it)"
        return
    fi
    if ! id -u "$USER_NAME" >/dev/null 2>&1; then
        if command -v useradd >/dev/null 2>&1; then
            if grep -q "^$USER_NAME:" /etc/group; then group_option="-g $USER_NAME"
            else group_option=--user-group; fi
            # shellcheck disable=SC2086
            useradd --system $group_option --no-create-home --home-dir /nonexistent \
                --shell /bin/false "$USER_NAME" || die "cannot create the user $USER_NAME"
        elif command -v adduser >/dev/null 2>&1; then
            grep -q "^$USER_NAME:" /etc/group || addgroup -S "$USER_NAME" ||
                die "cannot create the group $USER_NAME"
            adduser -S -D -H -h /nonexistent -s /bin/false -G "$USER_NAME" "$USER_NAME" ||
                die "cannot create the user $USER_NAME"
        else
            die "cannot create the user $USER_NAME: neither useradd nor adduser is here"
        fi
        echo "$PROG: created the system user $USER_NAME"
    fi
    if grep -q '^dialout:' /etc/group && ! id -Gn "$USER_NAME" | grep -qw dialout; then
        if command -v usermod >/dev/null 2>&1; then
            usermod -a -G dialout "$USER_NAME"
        else
            addgroup "$USER_NAME" dialout
        fi || die "cannot add $USER_NAME to the group dialout (the robot's tty)"
    fi
}

install_service() {
    # The directory and interpreter go into the unit's command lines: no
    # spaces, quotes or systemd specifiers (%).
    case $dir in
        *[!A-Za-z0-9._/+-]*)
            die "--service: the install directory '$dir' may only hold letters, digits" \
                "and . _ / + - (it goes into the service's command lines)" ;;
    esac
    if [ -z "$DESTDIR" ] && [ "$(id -u)" != 0 ]; then
        die "--service writes to /etc: run it as root, e.g. sudo sh $dir/install.sh --service"
    fi
    python=${STEREOGEST_PYTHON:-$(command -v python3)}
    case $python in
        /*) ;;
        *) die "--service: python3 not found on PATH (apt install python3 python3-numpy)" ;;
    esac
    case $python in
        *[!A-Za-z0-9._/+-]*) die "--service: python3's path '$python' has unusual characters" ;;
    esac
    src=$dir/sw_hps/service
    [ -f "$src/stereogest.service" ] || die "--service: $src/stereogest.service is missing" \
        "(not a stereogest install directory)"
    if [ -z "$init" ]; then
        # systemd's own test for "booted with systemd" (sd_booted).
        if [ -d /run/systemd/system ]; then init=systemd; else init=sysv; fi
    fi
    settings=$DESTDIR/etc/default/$NAME
    if [ -z "$bus" ]; then
        bus=devmem
        [ -e "$settings" ] && [ "$(bus_of "$settings")" = uio ] && bus=uio
        change_bus=0
    else
        change_bus=1
    fi
    ensure_user
    mkdir -p "$DESTDIR/etc/default" || die "cannot create $DESTDIR/etc/default"
    mkdir -p "$DESTDIR/etc/udev/rules.d" || die "cannot create $DESTDIR/etc/udev/rules.d"
    install_substituted "$src/60-$NAME.rules" "$DESTDIR/etc/udev/rules.d/60-$NAME.rules" 644
    if [ -z "$DESTDIR" ] && command -v udevadm >/dev/null 2>&1; then
        udevadm control --reload && udevadm trigger --subsystem-match=uio ||
            echo "$PROG: udevadm could not apply the rule; it applies at the next boot" >&2
    fi
    echo "$PROG: installed /etc/udev/rules.d/60-$NAME.rules (the uio device: group" \
        "$USER_NAME, /dev/$NAME)"
    if [ "$init" = systemd ]; then
        mkdir -p "$DESTDIR/etc/systemd/system" || die "cannot create $DESTDIR/etc/systemd/system"
        install_substituted "$src/stereogest.service" "$DESTDIR/etc/systemd/system/$NAME.service" 644
        echo "$PROG: installed /etc/systemd/system/$NAME.service (for $dir, as the user" \
            "$USER_NAME)"
        dropin=$DESTDIR/etc/systemd/system/$NAME.service.d
        if [ "$bus" = devmem ]; then
            mkdir -p "$dropin" || die "cannot create $dropin"
            install_substituted "$src/stereogest-devmem.conf" "$dropin/devmem.conf" 644
            echo "$PROG: installed /etc/systemd/system/$NAME.service.d/devmem.conf" \
                "(--bus devmem: root with CAP_SYS_RAWIO until the bridge is mapped)"
        elif [ -e "$dropin/devmem.conf" ]; then
            rm -f "$dropin/devmem.conf" || die "cannot remove $dropin/devmem.conf"
            rmdir "$dropin" 2>/dev/null
            echo "$PROG: removed /etc/systemd/system/$NAME.service.d/devmem.conf (--bus uio)"
        fi
    else
        mkdir -p "$DESTDIR/etc/init.d" || die "cannot create $DESTDIR/etc/init.d"
        install_substituted "$src/stereogest.init" "$DESTDIR/etc/init.d/$NAME" 755
        echo "$PROG: installed /etc/init.d/$NAME (for $dir)"
    fi
    if [ -e "$settings" ]; then
        if [ "$change_bus" = 1 ] && [ "$(bus_of "$settings")" != "$bus" ]; then
            write_settings "$settings" "$settings"
            echo "$PROG: set $(bus_setting "$bus") in /etc/default/$NAME (your other settings kept)"
        else
            echo "$PROG: kept /etc/default/$NAME (your settings; the bundle's example is" \
                "$src/stereogest.default)"
        fi
    else
        write_settings "$src/stereogest.default" "$settings"
        echo "$PROG: installed /etc/default/$NAME (--bus $bus): set the robot link (--robot)" \
            "there"
    fi
    if [ "$init" = systemd ]; then
        if [ -z "$DESTDIR" ]; then
            systemctl daemon-reload || die "systemctl daemon-reload failed"
        fi
        echo "$PROG: start it now and at every boot: systemctl enable --now $NAME" \
            "(log: journalctl -u $NAME -f)"
    else
        echo "$PROG: start it now: /etc/init.d/$NAME start; at every boot:" \
            "update-rc.d $NAME defaults (Debian), or ln -s ../init.d/$NAME /etc/rc5.d/S90$NAME"
    fi
}

# Tell whether the service runs code from before this install (it keeps the
# modules it loaded until restarted; a reload only re-reads the model file).
restart_hint() {
    if command -v systemctl >/dev/null 2>&1 && systemctl is-active --quiet "$NAME" 2>/dev/null; then
        echo "$PROG: the service still runs the previous code: systemctl restart $NAME"
    elif [ -x "/etc/init.d/$NAME" ] && "/etc/init.d/$NAME" status >/dev/null 2>&1; then
        echo "$PROG: the service still runs the previous code: /etc/init.d/$NAME restart"
    fi
}

install_tree() {  # TARBALL DIR
    tarball=$1
    target=$2
    [ -f "$tarball" ] || die "no bundle '$tarball' (make hps-bundle writes build/stereogest-hps.tar.gz)"
    while :; do
        case $target in
            */) target=${target%/} ;;
            *) break ;;
        esac
    done
    base=$(basename "$target")
    case $base in
        '' | . | .. | /) usage_error "DIR must name a directory to create or replace, got '$2'" ;;
    esac
    parent=$(dirname "$target")
    mkdir -p "$parent" || die "cannot create $parent"
    parent=$(cd "$parent" && pwd) || die "cannot enter $parent"
    dir=$parent/$base
    if [ -e "$dir" ] && [ ! -d "$dir" ]; then
        die "$dir exists and is not a directory"
    fi
    new=$dir.new
    rm -rf "$new" 2>/dev/null
    [ -e "$new" ] && die "cannot remove the leftover $new (files of another user? sudo rm -rf $new)"
    mkdir "$new" || die "cannot create $new"
    if ! tar -xzf "$tarball" -C "$new"; then
        rm -rf "$new"
        die "cannot unpack $tarball (a whole bundle? make deploy uploads it again)"
    fi
    if [ ! -f "$new/sw_hps/__main__.py" ] || [ ! -f "$new/model.json" ]; then
        rm -rf "$new"
        die "$tarball is not a stereogest bundle (no sw_hps/__main__.py or model.json)"
    fi
    # Swap by renames: the new tree appears whole, never mixed with the old one.
    old=$dir.old
    rm -rf "$old" 2>/dev/null
    # A leftover old tree that cannot be removed (root-owned files) must not
    # receive the next rename: mv would move the tree inside it.
    [ -e "$old" ] && old=$dir.old.$$
    replaced=0
    if [ -d "$dir" ]; then
        mv "$dir" "$old" || {
            rm -rf "$new"
            die "cannot move $dir aside"
        }
        replaced=1
    fi
    if ! mv "$new" "$dir"; then
        [ "$replaced" = 1 ] && mv "$old" "$dir"
        rm -rf "$new"
        die "cannot move $new to $dir"
    fi
    if [ "$replaced" = 1 ]; then
        if rm -rf "$old" 2>/dev/null; then
            echo "$PROG: installed $dir (the previous tree is replaced)"
        else
            echo "$PROG: installed $dir; could not remove the previous tree $old" \
                "(files written as root?): sudo rm -rf $old" >&2
        fi
        restart_hint
    else
        echo "$PROG: installed $dir"
    fi
}

service=0
init=
bus=
while [ $# -gt 0 ]; do
    case $1 in
        --service) service=1 ;;
        --init)
            [ $# -ge 2 ] || usage_error "--init needs systemd or sysv"
            init=$2
            shift
            ;;
        --init=*) init=${1#--init=} ;;
        --bus)
            [ $# -ge 2 ] || usage_error "--bus needs devmem or uio"
            bus=$2
            shift
            ;;
        --bus=*) bus=${1#--bus=} ;;
        -h | --help)
            sed -n '2,/^# Exit status/s/^# \{0,1\}//p' "$0"
            exit 0
            ;;
        --) shift; break ;;
        -*) usage_error "unknown option '$1'" ;;
        *) break ;;
    esac
    shift
done
case $init in
    '' | systemd | sysv) ;;
    *) usage_error "--init must be systemd or sysv, got '$init'" ;;
esac
case $bus in
    '' | devmem | uio) ;;
    *) usage_error "--bus must be devmem or uio, got '$bus'" ;;
esac
if [ -n "$bus" ] && [ "$service" = 0 ]; then
    usage_error "--bus sets the service's bus: only with --service"
fi

case $# in
    0)
        [ "$service" = 1 ] || usage_error "a TARBALL (or --service alone, for this tree) is needed"
        dir=$(cd "$(dirname "$0")" && pwd) || die "cannot find the directory of $0"
        # Run from its source in a repository checkout: the checkout is the tree.
        case $dir in
            */sw_hps/service) [ -f "$dir/../__main__.py" ] && dir=${dir%/sw_hps/service} ;;
        esac
        install_service
        ;;
    1 | 2)
        install_tree "$1" "${2:-$NAME}"
        if [ "$service" = 1 ]; then
            install_service
        fi
        ;;
    *) usage_error "too many arguments: $*" ;;
esac
exit 0
