#!/usr/bin/python3
"""ctest helper: checks evaluate_sequence's JSON against floors (and that its plots were drawn).

  check_sequence_json.py SEQUENCE.json [--min-localized F] [--max-median-position M]
                         [--max-median-heading DEG] [--min-segment-nees-mean N] [--max-segment-nees-mean N]
                         [--min-segment-frames N] [--max-beyond-95 F] [--max-segment-beyond-95 F] [--plots]
Exit 1 naming the figure that misses its floor."""
import argparse
import json
import os
import sys


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("json")
    parser.add_argument("--min-localized", type=float, default=0.0)
    parser.add_argument("--max-median-position", type=float, default=float("inf"))
    parser.add_argument("--max-median-heading", type=float, default=float("inf"))
    # The covariance's honesty per segment (a turn whose fixes are wrong while claiming mm shows
    # here long before it moves the median).
    parser.add_argument("--max-segment-nees-mean", type=float, default=float("inf"))
    # ... and from the other side: a covariance that claims far more than the errors are.
    parser.add_argument("--min-segment-nees-mean", type=float, default=0.0)
    # The two bounds above apply to segments with at least this many localized frames: the mean of
    # a few NEES values is itself uncertain (five independent 3-DoF values: a standard deviation of
    # 1.1 about 3), and consecutive fixes against one keyframe are not independent.
    parser.add_argument("--min-segment-frames", type=int, default=1)
    # The share of poses beyond their 95 % bound over the run.
    parser.add_argument("--max-beyond-95", type=float, default=1.0)
    # The same per segment of at least --min-segment-frames localized frames (issue 49's band).
    parser.add_argument("--max-segment-beyond-95", type=float, default=1.0)
    parser.add_argument("--plots", action="store_true")
    args = parser.parse_args()
    with open(args.json) as f:
        doc = json.load(f)
    summary = doc["summary"]
    problems = []
    if summary["fraction_localized"] < args.min_localized:
        problems.append("fraction localized %.3f < %.3f" % (summary["fraction_localized"], args.min_localized))
    median = summary["position_error_median_m"]
    if median is None or median > args.max_median_position:
        problems.append("median position error %s m > %.3f m" % (median, args.max_median_position))
    heading = summary["heading_error_median_deg"]
    if args.max_median_heading != float("inf") and (heading is None or heading > args.max_median_heading):
        problems.append("median heading error %s deg > %.3f deg" % (heading, args.max_median_heading))
    checks_nees = args.max_segment_nees_mean != float("inf") or args.min_segment_nees_mean > 0.0
    for segment in doc.get("segments", []) if checks_nees else []:
        if segment.get("localized", 0) < args.min_segment_frames:
            continue
        nees = segment.get("nees_mean")
        if nees is None or nees > args.max_segment_nees_mean:
            problems.append("segment '%s': NEES mean %s > %.1f" % (segment.get("name"), nees, args.max_segment_nees_mean))
        elif nees < args.min_segment_nees_mean:
            problems.append("segment '%s': NEES mean %s < %.1f" % (segment.get("name"), nees, args.min_segment_nees_mean))
        segment_beyond = segment.get("nees_fraction_beyond_95")
        if args.max_segment_beyond_95 < 1.0 and (segment_beyond is None or segment_beyond > args.max_segment_beyond_95):
            problems.append("segment '%s': %s of the poses beyond their 95 %% bound > %.2f" %
                            (segment.get("name"), segment_beyond, args.max_segment_beyond_95))
    beyond = summary.get("nees_fraction_beyond_95")
    if args.max_beyond_95 < 1.0 and (beyond is None or beyond > args.max_beyond_95):
        problems.append("%s of the poses beyond their 95 %% bound > %.2f" % (beyond, args.max_beyond_95))
    if len(doc["frames"]) != summary["frames"] or not doc["keyframes"]:
        problems.append("frames or keyframes missing from the JSON")
    if args.plots:
        stem = os.path.splitext(args.json)[0]
        for suffix in ("_top.png", "_error.png", "_nees.png"):
            if not os.path.getsize(stem + suffix) > 0:
                problems.append("no plot " + stem + suffix)
    print("%d/%d frames localized, median position error %s m, median heading error %s deg, NEES mean %s" %
          (summary["localized"], summary["frames"], median, heading, summary["nees_mean"]))
    for p in problems:
        print("check_sequence_json: " + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
