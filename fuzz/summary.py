#!/usr/bin/env python3
"""Sums the fuzzing logs of fuzz/logs/ (one per fuzz/run.sh run) into the table of
docs/robustness.md: per target, runs, executions, seconds, executions per second, the last
run's coverage (libFuzzer's `cov` edges and `ft` features), corpus size, the slowest
input, peak memory, and the findings (crash / timeout / oom / leak) with their files.

    python3 fuzz/summary.py            # Markdown table
"""
import pathlib
import re
import sys
from datetime import datetime

LOGS = pathlib.Path(__file__).resolve().parent / "logs"


def started_to_end(log):
    """Seconds of a run that stopped on a finding (no "Done" line): from the start time
    in the log's name (fuzz/run.sh) to the log's last write."""
    try:
        start = datetime.strptime("-".join(log.stem.split("-")[-2:]), "%Y%m%d-%H%M%S")
    except ValueError:
        return None
    return max(0, int(log.stat().st_mtime - start.timestamp()))


def runs(target):
    for log in sorted(LOGS.glob(f"{target}-*.log")):
        text = log.read_text(errors="replace")
        status = re.findall(r"^#(\d+)\s+\w+\s+cov: (\d+) ft: (\d+) corp: (\d+)/(\S+) .*?exec/s: (\d+)", text, re.M)
        execs = re.search(r"stat::number_of_executed_units:\s+(\d+)", text)
        seconds = re.search(r"Done \d+ runs in (\d+) second", text)
        slow = re.search(r"stat::slowest_unit_time_sec:\s+(\d+)", text)
        rss = re.search(r"stat::peak_rss_mb:\s+(\d+)", text)
        found = re.findall(r"SUMMARY: libFuzzer: ([\w-]+)", text)
        artifact = re.findall(r"Test unit written to (\S+)", text)
        last = status[-1] if status else None
        yield {
            "log": log.name,
            "execs": int(execs.group(1)) if execs else (int(last[0]) if last else 0),
            "seconds": int(seconds.group(1)) if seconds else started_to_end(log),
            "cov": int(last[1]) if last else 0,
            "ft": int(last[2]) if last else 0,
            "corpus": f"{last[3]} ({last[4]})" if last else "-",
            "slowest": int(slow.group(1)) if slow else None,
            "rss": int(rss.group(1)) if rss else None,
            "found": list(zip(found, artifact)) if found else [],
            "finished": execs is not None,
        }


def main():
    targets = sys.argv[1:] or ["scene_toml", "obj", "ply", "mitsuba_xml", "image", "scene_values"]
    print("| target | runs | executions | seconds | exec/s | cov (edges) | ft (features) | corpus | slowest input | peak rss | findings |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for t in targets:
        rs = list(runs(t))
        if not rs:
            continue
        execs = sum(r["execs"] for r in rs)
        secs = sum(r["seconds"] or 0 for r in rs)
        last = max(rs, key=lambda r: r["ft"])
        slow = max((r["slowest"] or 0) for r in rs)
        rss = max((r["rss"] or 0) for r in rs)
        found = [f"{kind} ({pathlib.Path(a).name})" for r in rs for kind, a in r["found"]]
        running = "" if all(r["finished"] for r in rs) else " (running)"
        rate = f"{execs / secs:.0f}" if secs else "-"
        print(f"| {t} | {len(rs)}{running} | {execs:,} | {secs:,} | {rate} | {last['cov']} | {last['ft']} | {last['corpus']} | {slow} s | {rss} MB | {', '.join(found) or 'none'} |")


if __name__ == "__main__":
    main()
