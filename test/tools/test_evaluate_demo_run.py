#!/usr/bin/python3
"""evaluate_demo_run judges a run by the controller's last state as well as by the errors: a robot
that never left the start is 0 m from a loop's end pose, and must not pass as a success. And it
scores the published pose (repeat_node/pose) against the ground truth at the pose's stamp,
interpolated, with the NEES of the published covariance.

  test_evaluate_demo_run.py EVALUATE_DEMO_RUN WORLD ROUTE_DIR WORK_DIR

Writes bags of ground truth and controller state (a lap round the route's keyframes that
finished; the same with each frame's keyframe, one keyframe's poses claiming a tenth of their
variance; a robot that waited at the start) and checks the exit codes (0 and 3) and metrics: the
scores per keyframe, and the summary naming the keyframe that claims too little.
"""
import collections
import json
import math
import os
import subprocess
import sys

import rosbag
import rospy
import yaml
from geometry_msgs.msg import PoseWithCovarianceStamped
from homography_teach_repeat.msg import HeadingCorrectionStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import String


# Published poses: 0.05 m off in x with a 0.05 m sigma (NEES 1 each), stamped half-way between
# two ground-truth samples 0.1 s apart, written after both (as an image's pose arrives late).
POSE_OFFSET_X = 0.05
POSE_COVARIANCE = [0.0025, 0.0025, 1e-4]


def write_bag(path, poses, state, with_estimates=False, keyframe_of=None, overconfident_keyframe=None,
              tracked=lambda i: i % 2 == 1):
    """keyframe_of(i): the keyframe pose i was fixed against (a heading correction with its stamp;
    None: a failed frame); overconfident_keyframe: whose poses claim a tenth of the variance;
    tracked(i): whether pose i's fix was tracked (its heading correction's flag)."""
    with rosbag.Bag(path, 'w') as bag:
        t = rospy.Time(1.0)
        for i, (x, y, yaw) in enumerate(poses):
            m = Odometry()
            m.header.stamp = t
            m.pose.pose.position.x, m.pose.pose.position.y = x, y
            m.pose.pose.orientation.z, m.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            bag.write('ground_truth', m, t)
            if with_estimates and i > 0:
                px, py, pyaw = poses[i - 1]
                mid_yaw = pyaw + math.atan2(math.sin(yaw - pyaw), math.cos(yaw - pyaw)) / 2
                e = PoseWithCovarianceStamped()
                e.header.stamp = t - rospy.Duration(0.05)
                e.header.frame_id = 'map'
                e.pose.pose.position.x, e.pose.pose.position.y = (px + x) / 2 + POSE_OFFSET_X, (py + y) / 2
                e.pose.pose.orientation.z, e.pose.pose.orientation.w = math.sin(mid_yaw / 2), math.cos(mid_yaw / 2)
                keyframe = keyframe_of(i) if keyframe_of else None
                scale = 0.1 if keyframe is not None and keyframe == overconfident_keyframe else 1.0
                for row, variance in zip((0, 1, 5), POSE_COVARIANCE):
                    e.pose.covariance[6 * row + row] = scale * variance
                for row in (2, 3, 4):
                    e.pose.covariance[6 * row + row] = 1e6  # unobserved: z, roll, pitch
                bag.write('repeat_node/pose', e, t)
                if keyframe_of:
                    c = HeadingCorrectionStamped()
                    c.header.stamp = e.header.stamp
                    c.ok = keyframe is not None
                    c.reference_index = keyframe if keyframe is not None else -1
                    c.tracked = tracked(i)
                    bag.write('repeat_node/heading_correction', c, t)
            t += rospy.Duration(0.1)
        bag.write('controller_node/state', String(data=state), t)


def evaluate(program, world, route, bag, out):
    result = subprocess.run([program, '--world', world, '--route', route, '--bag', bag, '--laps', '1',
                             '--mode', 'mu', '--out', out], stdout=subprocess.PIPE, universal_newlines=True)
    with open(os.path.join(out, 'metrics.json')) as f:
        return result.returncode, json.load(f), result.stdout


def main():
    program, world, route, work = sys.argv[1:5]
    os.makedirs(work, exist_ok=True)
    keyframes = yaml.safe_load(open(os.path.join(route, 'route.yaml')))['keyframes']
    path = [(k['pose']['x'], k['pose']['y'], k['pose']['yaw']) for k in keyframes]
    lap = []
    for (x0, y0, yaw0), (x1, y1, _) in zip(path, path[1:] + path[:1]):
        for i in range(10):
            lap.append((x0 + (x1 - x0) * i / 10, y0 + (y1 - y0) * i / 10, yaw0))
    lap.append(path[0])
    failures = []

    write_bag(os.path.join(work, 'finished.bag'), lap, 'finished: end of the route', with_estimates=True)
    code, metrics, _ = evaluate(program, world, route, os.path.join(work, 'finished.bag'), os.path.join(work, 'finished'))
    if code != 0 or metrics['finished'] is not True:
        failures.append('a finished lap: exit %d, finished %s' % (code, metrics['finished']))
    if abs(metrics['distance_travelled_m'] - metrics['route_distance_m']) > 0.05:
        failures.append('a lap travelled %.3f m, the route is %.3f m' % (metrics['distance_travelled_m'],
                                                                          metrics['route_distance_m']))

    localization = metrics['localization']
    if (localization is None or localization['poses'] != len(lap) - 1 or localization['unscored_poses'] != 0
            or abs(localization['nees_mean'] - 1.0) > 1e-6 or abs(localization['position_err_rms_m'] - POSE_OFFSET_X) > 1e-6
            or localization['heading_err_rms_deg'] > 1e-6):
        failures.append('published poses 0.05 m off at a 0.05 m sigma, between two ground-truth samples: %s'
                        % localization)

    if localization is not None and localization.get('by_keyframe', 'absent') is not None:
        failures.append('a bag without heading corrections: by_keyframe %s, not null' % localization.get('by_keyframe'))

    # Each pose fixed against the keyframe its lap segment starts at (10 poses each; the first has 9,
    # pose 0 having no estimate), pose 25 a failed frame (no keyframe), keyframe 1's poses claiming
    # a tenth of their variance (NEES 10 each).
    keyframe_of = lambda i: None if i == 25 else (i // 10) % len(path)
    write_bag(os.path.join(work, 'by_keyframe.bag'), lap, 'finished: end of the route', with_estimates=True,
              keyframe_of=keyframe_of, overconfident_keyframe=1)
    code, metrics, stdout = evaluate(program, world, route, os.path.join(work, 'by_keyframe.bag'),
                                     os.path.join(work, 'by_keyframe'))
    by_keyframe = (metrics['localization'] or {}).get('by_keyframe') or []
    expected = collections.Counter(keyframe_of(i) for i in range(1, len(lap)) if keyframe_of(i) is not None)
    scored = {k['keyframe']: k for k in by_keyframe}
    if code != 0 or sorted(scored) != sorted(expected) or any(scored[k]['poses'] != n for k, n in expected.items()):
        failures.append('poses by keyframe: exit %d, %s, expected counts %s' % (code, by_keyframe, expected))
    else:
        for k, entry in scored.items():
            want = 10.0 if k == 1 else 1.0
            if abs(entry['nees_mean'] - want) > 1e-6:
                failures.append('keyframe %d: NEES mean %s, expected %s' % (k, entry['nees_mean'], want))
    # By the source of the fix: odd poses tracked, even ones detected (keyframe 1's NEES 10 each).
    sources = (metrics['localization'] or {}).get('by_fix_source') or {}
    for name, wanted in (('detected', 0), ('tracked', 1)):
        nees = [10.0 if keyframe_of(i) == 1 else 1.0 for i in range(1, len(lap))
                if keyframe_of(i) is not None and i % 2 == wanted]
        got = sources.get(name) or {}
        if got.get('poses') != len(nees) or abs(got.get('nees_mean', -1.0) - sum(nees) / len(nees)) > 1e-6:
            failures.append('poses of %s fixes: %s, expected %d with NEES mean %.3f'
                            % (name, got, len(nees), sum(nees) / len(nees)))
    if 'poses by the source of their fix: detected %d' % sum(
            1 for i in range(1, len(lap)) if keyframe_of(i) is not None and i % 2 == 0) not in stdout:
        failures.append('the summary does not count the poses by the source of their fix: %r' % stdout[-400:])
    if localization is not None and localization.get('by_fix_source', 'absent') is not None:
        failures.append('a bag without heading corrections: by_fix_source %s, not null'
                        % localization.get('by_fix_source'))
    named = 'claim too little (NEES mean above 6 over 10 or more poses): 1 (10.0 over 10)'
    if named not in stdout:
        failures.append('the summary does not name keyframe 1 as claiming too little: %r' % stdout[-400:])

    write_bag(os.path.join(work, 'waited.bag'), [path[0]] * 50, 'waiting: no localization yet')
    code, metrics, stdout = evaluate(program, world, route, os.path.join(work, 'waited.bag'), os.path.join(work, 'waited'))
    if code != 3 or metrics['finished'] is not False or metrics['distance_travelled_m'] != 0.0:
        failures.append('a robot that waited at the start: exit %d, finished %s, travelled %s' %
                        (code, metrics['finished'], metrics['distance_travelled_m']))
    if metrics['final_pos_err_m'] > 1e-9 or 'did NOT finish' not in stdout:
        failures.append('the waiting robot: final error %s, summary %r' % (metrics['final_pos_err_m'], stdout[-200:]))
    if metrics['localization'] is not None:
        failures.append('a bag without repeat_node/pose: localization %s, not null' % metrics['localization'])

    for failure in failures:
        print('FAIL: ' + failure)
    sys.exit(1 if failures else 0)


if __name__ == '__main__':
    main()
