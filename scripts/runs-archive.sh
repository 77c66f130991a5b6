#!/usr/bin/env bash
# Carries a `reproduce` grid's finished runs to another machine, for a grid run in parts on
# machines whose disks do not outlive the part (a fresh VM each time, a cluster's scratch space):
#
#   scripts/runs-archive.sh save OUT ARCHIVES      # the runs finished since the last save
#   scripts/runs-archive.sh restore ARCHIVES OUT   # every saved run, into a fresh OUT
#
# then `host-trainer reproduce ... --out OUT` carries on with the runs not yet finished, and
# `--merge` builds the page from OUT as if every run had been made there.
#
# `save` writes ARCHIVES/NNN.tar.xz (the next free number) holding, for every run of OUT that
# finished (its eval.json is written) and is in no earlier archive, the files the results page
# reads and a reader would want: config.toml, scenario.toml, eval.json, metrics.csv, the blobs
# and the run's sweep logs; the logs and markers of failed runs, so they still count as failed;
# and OUT's grid record and part records (grid.json, parts/*.json: commit and wall time of each
# part), whose newest copy wins on restore. It leaves out what a finished run no longer needs:
# checkpoints (about 20 MB a run, for resuming), locks and the learning-curve SVG (metrics.csv
# holds its numbers). Nothing new finished or failed: it says so and writes nothing. The archive is
# written under a temporary name and linked into place, so a killed save leaves no half archive
# and two saves never take the same number; tar and xz die with the script, and the next save
# removes a killed save's temporary.
#
# `restore` unpacks every archive in number order into OUT, which must be empty or absent: it
# never writes over runs that are already there, and a corrupt archive leaves OUT as it was. It
# unpacks only regular files and folders: an archive holding anything else (a symbolic link, a
# hard link, a device, a fifo) or a name that is absolute or climbs with `..` is refused before
# anything is unpacked, naming the archive and the member.
#
# Exit codes: 0 done, 1 a command failed, 2 bad arguments.
set -euo pipefail

usage() {
    echo "usage: $0 save OUT ARCHIVES | restore ARCHIVES OUT" >&2
    exit 2
}
die() {
    echo "runs-archive: $*" >&2
    exit 2
}
[[ $# -eq 3 ]] || usage

# tar and xz die with this script: killed with SIGKILL it runs no trap, and a pipeline left
# behind would go on writing a full-size temporary archive nobody will link into place. Each is
# a simple command of the script itself (not of a function or subshell), so its parent is this
# shell and the death signal follows the shell. The signal is armed only once setpriv runs, a
# moment after the fork: a shell killed in that moment would leave the child armed against its
# new parent (init), so, once armed, the child checks that its parent is still this shell and
# quits if not (the usual PR_SET_PDEATHSIG race, closed by the same check as in C).
with_us=()
if setpriv --pdeathsig KILL true 2>/dev/null; then
    # shellcheck disable=SC2016 # expanded by the child's bash, not here
    with_us=(setpriv --pdeathsig KILL -- bash -c '[[ $PPID == "$1" ]] || exit 1; shift; exec "$@"' with-us "$$")
fi

# Temporaries are named for this machine and the writer's pid (`.HOST.PID.`), and only this
# machine's are judged by pid: an archive folder on shared storage may hold another node's save
# under way, whose pid means nothing here.
host="$(uname -n)"

# Removes the temporaries ($1: a glob of this machine's names, `.HOST.PID.`) whose writer is
# gone: a save or restore killed with SIGKILL runs no trap.
remove_stale() {
    local f pid
    for f in $1; do
        [[ -e "$f" ]] || continue
        pid="$(sed -E 's/.*\.([0-9]+)\.[^/]*$/\1/' <<<"$f")"
        [[ "$pid" =~ ^[0-9]+$ ]] && ! kill -0 "$pid" 2>/dev/null && rm -rf "$f"
    done
    return 0
}

# The archives of a folder, in number order (NNN.tar.xz only).
archives_in() {
    find "$1" -maxdepth 1 -type f -name '[0-9][0-9][0-9].tar.xz' -printf '%f\n' | sort
}

# The member names of archive $1, once xz has checked the whole stream (its checksums and
# index, which tar alone may stop reading before) and tar has listed it to its end.
members_of() {
    xz -tq "$1" 2>/dev/null && LC_ALL=C tar -tJf "$1" 2>/dev/null
}

# What a member of type letter $1 (as `tar -tv` shows it) is, in words.
member_kind() {
    case "$1" in
    l) echo "a symbolic link" ;;
    h) echo "a hard link" ;;
    c) echo "a character device" ;;
    b) echo "a block device" ;;
    p) echo "a fifo" ;;
    *) echo "a member of type '$1'" ;;
    esac
}

# Refuses (exit 1) archive $1 unless every member is a regular file or a folder with a relative
# name that stays inside OUT. Checked for every archive before the first is unpacked: a symbolic
# link one archive plants (`runs -> /elsewhere`) would carry the next archive's files out of OUT,
# and tar follows such a link when it unpacks through it.
check_members() {
    local a=$1 listing line type name
    listing="$(xz -tq "$a" 2>/dev/null && LC_ALL=C tar -tvJf "$a" 2>/dev/null)" || {
        echo "runs-archive: $a does not unpack; nothing restored" >&2
        exit 1
    }
    while IFS= read -r line; do
        type="${line:0:1}"
        # The name follows five columns: mode, owner/group, size, date, time.
        name="$(sed -E 's/^([^ ]+ +){5}//' <<<"$line")"
        if [[ "$type" != "-" && "$type" != "d" ]]; then
            echo "runs-archive: $a holds $(member_kind "$type") ($name): only files and" \
                "folders are restored; nothing restored" >&2
            exit 1
        fi
        if [[ "$name" == /* || "/$name/" == */../* ]]; then
            echo "runs-archive: $a holds $name, a name outside the folder it unpacks into;" \
                "nothing restored" >&2
            exit 1
        fi
    done <<<"$listing"
}

save() {
    local out=$1 dir=$2
    [[ -f "$out/grid.json" ]] ||
        die "$out holds no grid (no grid.json): not a reproduce --out folder"
    [[ ! -e "$dir" || -d "$dir" ]] || die "$dir exists and is not a folder"
    mkdir -p "$dir" 2>/dev/null || die "cannot create $dir"
    [[ -w "$dir" ]] || die "cannot write to $dir"
    dir="$(realpath "$dir")"
    cd "$out"

    # Runs in earlier archives, as their eval.json paths and failure markers.
    # Named like the other temporaries, so the next save removes a killed save's lists too.
    local scratch="${TMPDIR:-/tmp}/runs-archive.$host.$$"
    remove_stale "${TMPDIR:-/tmp}/runs-archive.$host.*"
    saved="$(mktemp "$scratch.saved.XXXXXX")"
    list="$(mktemp "$scratch.list.XXXXXX")"
    trap 'rm -f "$saved" "$list" "${tmp:-}"' EXIT
    # Each earlier archive is verified whole first: a corrupt one would hide the runs it holds
    # from this list, so they would be saved again, and restore refuses the whole set anyway.
    local a names
    while read -r a; do
        [[ -n "$a" ]] || continue
        names="$(members_of "$dir/$a")" || {
            echo "runs-archive: $dir/$a is corrupt or truncated (xz -t or tar -t fails):" \
                "replace it with a good copy before saving again; nothing saved" >&2
            exit 1
        }
        grep -E '/eval\.json$|\.failed$' <<<"$names" >>"$saved" || true
    done < <(archives_in "$dir")

    local eval run cell name new=0
    while read -r eval; do
        grep -qxF "$eval" "$saved" && continue
        run="$(dirname "$eval")"
        cell="$(dirname "$run")"
        name="$(basename "$run")"
        find "$run" -maxdepth 1 -type f ! -name 'checkpoint*' ! -name '.*' ! -name '*.svg' \
            ! -name '*.tmp' | sort >>"$list"
        # A cell without sweep logs is no error (pipefail would make it one, silently).
        { find "$cell/sweep-logs" -maxdepth 1 -type f -name "$name.*" 2>/dev/null || true; } |
            sort >>"$list"
        new=$((new + 1))
    done < <(find runs -mindepth 3 -maxdepth 3 -type f -name eval.json | sort)
    # Failed runs not saved yet: their markers and logs, so they still count as failed.
    local marker
    while read -r marker; do
        grep -qxF "$marker" "$saved" && continue
        echo "$marker" >>"$list"
        if [[ -f "${marker%.failed}.log" ]]; then echo "${marker%.failed}.log" >>"$list"; fi
        new=$((new + 1))
    done < <(find runs -mindepth 3 -maxdepth 3 -path '*/sweep-logs/*.failed' -type f | sort)
    if [[ $new -eq 0 ]]; then
        echo "runs-archive: no run of $out finished or failed since the last save; nothing written"
        return 0
    fi
    echo grid.json >>"$list"
    find parts -maxdepth 1 -type f -name '*.json' 2>/dev/null >>"$list" || true

    local last next
    last="$(archives_in "$dir" | tail -n 1)"
    last="${last%.tar.xz}"
    next="$(printf '%03d' $((10#${last:-000} + 1)))"
    remove_stale "$dir/.[0-9][0-9][0-9].tar.xz.$host.*.tmp"
    tmp="$dir/.$next.tar.xz.$host.$$.tmp"
    "${with_us[@]}" tar -cf - --no-recursion -T "$list" | "${with_us[@]}" xz -9 >"$tmp"
    # A hard link fails if the name is taken: a save racing this one keeps its own archive.
    ln "$tmp" "$dir/$next.tar.xz" 2>/dev/null ||
        die "$dir/$next.tar.xz appeared while saving (another save?); run save again"
    rm -f "$tmp"
    echo "runs-archive: $new finished or failed runs of $out saved in $dir/$next.tar.xz" \
        "($(du -k "$dir/$next.tar.xz" | cut -f1) KiB)"
}

restore() {
    local dir=$1 out=$2
    [[ -d "$dir" ]] || die "no archive folder $dir"
    local names
    names="$(archives_in "$dir")"
    [[ -n "$names" ]] || die "$dir holds no archive (NNN.tar.xz)"
    if [[ -e "$out" ]]; then
        [[ -d "$out" ]] || die "$out exists and is not a folder"
        [[ -z "$(ls -A "$out")" ]] ||
            die "$out is not empty: restore writes only into a fresh folder"
    fi
    local a
    for a in $names; do check_members "$dir/$a"; done
    # Unpacked into a staging folder and moved into place whole: a corrupt archive leaves OUT as
    # it was. An absent OUT is staged beside it and renamed into place; its parent is made
    # first, since on a fresh clone `runs/` does not exist yet. An existing (empty) OUT is
    # staged inside itself and its entries moved up, so OUT may be `.` or a mount point.
    local parent
    if [[ -d "$out" ]]; then parent="$out"; else parent="$(dirname "$out")"; fi
    mkdir -p "$parent" 2>/dev/null || die "cannot create $parent, the folder that holds $out"
    remove_stale "$parent/.restore.$host.*"
    staging="$(mktemp -d "$parent/.restore.$host.$$.XXXXXX" 2>/dev/null)" ||
        die "cannot write in $parent"
    trap 'rm -rf "$staging"' EXIT
    chmod go+rx "$staging"
    for a in $names; do
        "${with_us[@]}" tar -xJf "$dir/$a" -C "$staging" || {
            echo "runs-archive: $dir/$a does not unpack; $out left as it was" >&2
            exit 1
        }
    done
    if [[ -d "$out" ]]; then
        find "$staging" -mindepth 1 -maxdepth 1 -exec mv -t "$out" {} +
        rmdir "$staging"
    else
        mv -T "$staging" "$out"
    fi
    echo "runs-archive: $(find "$out/runs" -mindepth 3 -maxdepth 3 -name eval.json | wc -l)" \
        "finished runs restored into $out from $(wc -w <<<"$names") archives"
}

case "$1" in
save) save "$2" "$3" ;;
restore) restore "$2" "$3" ;;
*) usage ;;
esac
