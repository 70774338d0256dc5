#!/usr/bin/env bash
# Carry a study's sweep over from one session to the next (docs/reproduction.md "Carrying a study over").
#
# The development machine starts each session from a fresh checkout: `results/` is lost, and a case
# still running is lost with its saved state unless both are committed. This script packs what a
# stopped sweep has into `data/` and unpacks it again:
#
#   scripts/carry-over.sh save    NAME   # results/thesis/NAME.db → data/thesis/NAME.db (finished cases,
#                                        # thin export) + data/carry-over/NAME.tar.xz (the whole
#                                        # database and the saved states of the cases in flight)
#   scripts/carry-over.sh restore NAME   # data/carry-over/NAME.tar.xz → results/thesis/
#
# then rerun the study's sweep files into results/thesis/NAME.db: finished cases are skipped, the
# cases in flight resume from their saved states (a resumed case without its HDF5 file starts a new
# one for its later snapshots). Stop the sweep (kill it) before `save`: a killed sweep loses only
# the steps since each case's last saved state.
set -euo pipefail
cd "$(dirname "$0")/.."

usage() {
	echo "usage: $0 save|restore NAME (a database results/thesis/NAME.db)" >&2
	exit 2
}
[ $# -eq 2 ] || usage
action=$1
name=$2
results=results/thesis
data=data/thesis
db=$results/$name.db
states=$results/$name
pack=data/carry-over/$name.tar.xz
bin=${XPFLOW:-${CARGO_TARGET_DIR:-target}/release/xpflow}

case $action in
save)
	[ -f "$db" ] || { echo "no database $db" >&2; exit 1; }
	if pgrep -f "xpflow[^ ]* sweep .*--db $db" >/dev/null; then
		echo "a sweep still writes $db: stop it first" >&2
		exit 1
	fi
	tmp=$(mktemp -d)
	trap 'rm -rf "$tmp"' EXIT
	# the finished cases as the shipped dataset
	"$bin" export --db "$db" --out "$tmp/$name.db" --thin | tee "$tmp/export.log"
	if grep -q '^exported 0 cases' "$tmp/export.log"; then
		echo "no finished case yet: $data/$name.db left as it was"
	else
		mv "$tmp/$name.db" "$data/$name.db"
	fi
	# the whole database (one consistent copy) and the saved states of the unfinished cases
	mkdir -p "$tmp/pack/$name" data/carry-over
	python3 -c 'import sqlite3, sys; sqlite3.connect("file:" + sys.argv[1] + "?mode=ro", uri=True).execute("VACUUM INTO ?", (sys.argv[2],))' \
		"$db" "$tmp/pack/$name.db"
	# in the copy, the killed sweep's cases are interrupted (pending, no owner), as a sweep resets
	# them when their process is gone: the next machine may have another host name, and a case
	# claimed on another host counts as running there
	python3 -c 'import sqlite3, sys; c = sqlite3.connect(sys.argv[1]); c.execute("UPDATE cases SET status = '"'"'pending'"'"', owner = NULL, owner_pid = NULL WHERE status = '"'"'running'"'"'"); c.commit()' \
		"$tmp/pack/$name.db"
	if [ -d "$states" ]; then
		# (and the finished undisturbed preludes its extrusion cases share)
		find "$states" -maxdepth 1 \( -name '*.resume.json' -o -name 'undisturbed-*.json' \) \
			-exec cp {} "$tmp/pack/$name/" \;
	fi
	tar -C "$tmp/pack" -cJf "$pack" "$name.db" "$name"
	echo "saved: $pack ($(du -h "$pack" | cut -f1);" \
		"$(find "$tmp/pack/$name" -name '*.resume.json' | wc -l) cases in flight)"
	;;
restore)
	[ -f "$pack" ] || { echo "no carried-over sweep $pack" >&2; exit 1; }
	if [ -e "$db" ]; then
		echo "$db exists: move it away first (restore does not overwrite a database)" >&2
		exit 1
	fi
	mkdir -p "$results"
	tar -C "$results" -xJf "$pack"
	echo "restored: $db and $(find "$states" -name '*.resume.json' | wc -l) saved states;" \
		"rerun the study's sweep files into $db"
	;;
*) usage ;;
esac
