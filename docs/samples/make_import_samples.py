#!/usr/bin/env python3
"""Writes the CSV samples of docs/import.md: files as a watch app and a location system's
export write them. Deterministic; run from the repository root:

    python3 docs/samples/make_import_samples.py

- watch_batched.csv: a 50-Hz wrist watch (a 1-Hz arm swing on gravity) logged by a phone app
  in a comma-decimal locale: `;` between columns, decimal commas, local date-times at +02:00,
  and batched delivery: 4 to 6 samples every 100 ms, each stamped on arrival 0.4 ms apart.
- tag_fixes.tsv: the same person's UWB tag at 10 Hz, tab-separated, the same local clock,
  with two rows swapped and one row repeated (what a logger with two writer threads leaves).
"""
import math
from datetime import datetime, timedelta

START = datetime(2019, 9, 12, 14, 3, 21, 250000)  # local time, UTC+02:00
SECONDS = 10


def stamp(t_s):
    return (START + timedelta(seconds=t_s)).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]


def comma(x, digits=4):
    return f"{x:.{digits}f}".replace(".", ",")


def watch():
    rows = ["time;acc_x (m/s^2);acc_y (m/s^2);acc_z (m/s^2);gyr_x (deg/s);gyr_y (deg/s);gyr_z (deg/s)"]
    sizes = [5, 5, 4, 6, 5, 6, 5, 4]
    n = 0
    for b in range(SECONDS * 10):
        k = sizes[b % len(sizes)]
        sent_s = (b + 1) * 0.1 + 0.003
        for i in range(k):
            t = n / 50.0
            n += 1
            w = 2 * math.pi * t
            values = [2.0 * math.sin(w), 0.5 * math.cos(w), 9.81 + 0.3 * math.sin(2 * w),
                      5.0 * math.sin(w), 2.0 * math.cos(w), 60.0 * math.cos(w)]
            arrived_s = sent_s - (k - 1 - i) * 0.0004
            rows.append(";".join([stamp(arrived_s)] + [comma(v) for v in values]))
    return rows


def tag():
    rows = ["time\ttag\tx (m)\ty (m)\tz (m)"]
    for n in range(SECONDS * 10):
        t = n / 10.0
        rows.append(f"{stamp(t)}\ttag1\t{1.0 + 0.8 * t:.3f}\t{2.0 + 0.1 * math.sin(t):.3f}\t1.300")
    rows[21], rows[22] = rows[22], rows[21]
    rows.insert(51, rows[50])
    return rows


for name, rows in [("watch_batched.csv", watch()), ("tag_fixes.tsv", tag())]:
    with open(f"docs/samples/{name}", "w") as f:
        f.write("\n".join(rows) + "\n")
