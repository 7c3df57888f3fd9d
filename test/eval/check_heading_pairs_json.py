#!/usr/bin/python3
"""Checks evaluate_heading_pairs' OUT/heading_pairs.json: every method scored on every pair (estimate,
error, status), the summary fields, and optional bounds:
  check_heading_pairs_json.py FILE [--max-error-rate METHOD=FRACTION ...] [--max-no-estimate METHOD=FRACTION ...]
                               [--plots]
Exit 1 with the reason when a check fails."""
import argparse
import json
import os
import sys


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("json")
    parser.add_argument("--max-error-rate", action="append", default=[])
    parser.add_argument("--max-no-estimate", action="append", default=[], help="the share of pairs without one")
    parser.add_argument("--plots", action="store_true", help="the PNG beside the JSON must exist")
    args = parser.parse_args()
    with open(args.json) as f:
        doc = json.load(f)
    problems = []
    methods = doc["methods"]
    if doc["default_method"] not in methods and doc["default_method"] is not None:
        print("note: the default method %s was not run" % doc["default_method"])
    for name, m in methods.items():
        for key in ("error_rate", "failures", "no_estimate", "pairs", "time_per_pair_ms"):
            if key not in m:
                problems.append("%s: no %s" % (name, key))
        if not 0.0 <= m["error_rate"] <= 1.0:
            problems.append("%s: error_rate %s outside [0, 1]" % (name, m["error_rate"]))
    for p in doc["pair_results"]:
        for name in methods:
            r = p["methods"].get(name)
            if r is None or not {"estimate_px", "error_px", "status", "failed"} <= set(r):
                problems.append("pair %s > %s: method %s incomplete" % (p["reference"], p["current"], name))
                break
    for bound in args.max_error_rate:
        name, value = bound.split("=")
        if name not in methods:
            problems.append("no method %s" % name)
        elif methods[name]["error_rate"] > float(value):
            problems.append("%s: error rate %.4f above %s" % (name, methods[name]["error_rate"], value))
    for bound in args.max_no_estimate:
        name, value = bound.split("=")
        if name not in methods:
            problems.append("no method %s" % name)
        elif methods[name]["no_estimate"] > float(value) * methods[name]["pairs"]:
            problems.append("%s: %d of %d pairs without an estimate, above %s" % (
                name, methods[name]["no_estimate"], methods[name]["pairs"], value))
    if args.plots and not os.path.exists(os.path.splitext(args.json)[0] + ".png"):
        problems.append("no plot beside the JSON")
    for name, m in methods.items():
        print("%-20s error rate %.4f (%d of %d; %d without an estimate)" % (name, m["error_rate"], m["failures"],
                                                                           m["pairs"], m["no_estimate"]))
    for p in problems:
        print("FAIL: " + p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
