#!/bin/sh
# Install (or redeploy) the stereogest board bundle on the board; POSIX sh, for
# BusyBox as for Debian. `make deploy` runs it through ssh; the bundle ships
# it as install.sh (the source is sw_hps/service/install.sh).
#
#   sh install.sh [--service] [--init systemd|sysv] TARBALL [DIR]
#       Unpack TARBALL into a fresh directory beside DIR (default: stereogest,
#       relative to the current directory), then swap it in by renaming: the
#       previous tree becomes DIR.old and is removed, so a module deleted from
#       the bundle and the previous tree's __pycache__ never survive.
#   sh DIR/install.sh --service [--init systemd|sysv]
#       Only install the service for the tree holding this script.
#
# --service (root) installs the systemd unit /etc/systemd/system/stereogest.service
# (or, without systemd or with --init sysv, /etc/init.d/stereogest) for DIR, and
# /etc/default/stereogest (the application's arguments) unless it exists; then
# prints how to enable it. DESTDIR=/some/root writes under that root instead
# (no root needed, no systemctl call): for packaging and tests.
# Exit status: 0 done, 1 a step failed (that step changed nothing), 2 bad usage.

NAME=stereogest
PROG=install.sh

die() {
    echo "$PROG: error: $*" >&2
    exit 1
}

usage_error() {
    echo "$PROG: error: $*" >&2
    echo "usage: sh install.sh [--service] [--init systemd|sysv] TARBALL [DIR]" \
        "| sh DIR/install.sh --service [--init systemd|sysv]" >&2
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
    mkdir -p "$DESTDIR/etc/default" || die "cannot create $DESTDIR/etc/default"
    if [ "$init" = systemd ]; then
        mkdir -p "$DESTDIR/etc/systemd/system" || die "cannot create $DESTDIR/etc/systemd/system"
        install_substituted "$src/stereogest.service" "$DESTDIR/etc/systemd/system/$NAME.service" 644
        echo "$PROG: installed /etc/systemd/system/$NAME.service (for $dir)"
    else
        mkdir -p "$DESTDIR/etc/init.d" || die "cannot create $DESTDIR/etc/init.d"
        install_substituted "$src/stereogest.init" "$DESTDIR/etc/init.d/$NAME" 755
        echo "$PROG: installed /etc/init.d/$NAME (for $dir)"
    fi
    if [ -e "$DESTDIR/etc/default/$NAME" ]; then
        echo "$PROG: kept /etc/default/$NAME (your settings; the bundle's example is" \
            "$src/stereogest.default)"
    else
        cp "$src/stereogest.default" "$DESTDIR/etc/default/$NAME.tmp" &&
            chmod 644 "$DESTDIR/etc/default/$NAME.tmp" &&
            mv "$DESTDIR/etc/default/$NAME.tmp" "$DESTDIR/etc/default/$NAME" ||
            die "cannot write /etc/default/$NAME"
        echo "$PROG: installed /etc/default/$NAME: set the robot link (--robot) and the bus there"
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
while [ $# -gt 0 ]; do
    case $1 in
        --service) service=1 ;;
        --init)
            [ $# -ge 2 ] || usage_error "--init needs systemd or sysv"
            init=$2
            shift
            ;;
        --init=*) init=${1#--init=} ;;
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

case $# in
    0)
        [ "$service" = 1 ] || usage_error "a TARBALL (or --service alone, for this tree) is needed"
        dir=$(cd "$(dirname "$0")" && pwd) || die "cannot find the directory of $0"
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
