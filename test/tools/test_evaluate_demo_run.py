#!/usr/bin/python3
"""evaluate_demo_run judges a run by the controller's last state as well as by the errors: a robot
that never left the start is 0 m from a loop's end pose, and must not pass as a success.

  test_evaluate_demo_run.py EVALUATE_DEMO_RUN WORLD ROUTE_DIR WORK_DIR

Writes two bags of ground truth and controller state (a lap round the route's keyframes that
finished; a robot that waited at the start) and checks the exit codes (0 and 3) and metrics.
"""
import json
import math
import os
import subprocess
import sys

import rosbag
import rospy
import yaml
from nav_msgs.msg import Odometry
from std_msgs.msg import String


def write_bag(path, poses, state):
    with rosbag.Bag(path, 'w') as bag:
        t = rospy.Time(1.0)
        for x, y, yaw in poses:
            m = Odometry()
            m.header.stamp = t
            m.pose.pose.position.x, m.pose.pose.position.y = x, y
            m.pose.pose.orientation.z, m.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            bag.write('ground_truth', m, t)
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

    write_bag(os.path.join(work, 'finished.bag'), lap, 'finished: end of the route')
    code, metrics, _ = evaluate(program, world, route, os.path.join(work, 'finished.bag'), os.path.join(work, 'finished'))
    if code != 0 or metrics['finished'] is not True:
        failures.append('a finished lap: exit %d, finished %s' % (code, metrics['finished']))
    if abs(metrics['distance_travelled_m'] - metrics['route_distance_m']) > 0.05:
        failures.append('a lap travelled %.3f m, the route is %.3f m' % (metrics['distance_travelled_m'],
                                                                          metrics['route_distance_m']))

    write_bag(os.path.join(work, 'waited.bag'), [path[0]] * 50, 'waiting: no localization yet')
    code, metrics, stdout = evaluate(program, world, route, os.path.join(work, 'waited.bag'), os.path.join(work, 'waited'))
    if code != 3 or metrics['finished'] is not False or metrics['distance_travelled_m'] != 0.0:
        failures.append('a robot that waited at the start: exit %d, finished %s, travelled %s' %
                        (code, metrics['finished'], metrics['distance_travelled_m']))
    if metrics['final_pos_err_m'] > 1e-9 or 'did NOT finish' not in stdout:
        failures.append('the waiting robot: final error %s, summary %r' % (metrics['final_pos_err_m'], stdout[-200:]))

    for failure in failures:
        print('FAIL: ' + failure)
    sys.exit(1 if failures else 0)


if __name__ == '__main__':
    main()
