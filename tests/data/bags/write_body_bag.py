"""Write a rigid-body ROS 2 bag with Python's `rosbags` (the independent writer tests/bags.rs
checks spmcal's reader against), from two plain tables the test writes:

    joints.csv  ns,theta1,theta2,theta3            (sensor_msgs/msg/JointState on /joint_states)
    body.csv    ns,x,y,z,qx,qy,qz,qw               (the body's pose in frame `world`)

    python3 write_body_bag.py pose|transform|tf JOINTS BODY OUT_BAG

`pose`: geometry_msgs/msg/PoseStamped on /vrpn_mocap/wrist/pose (as vrpn_mocap publishes it);
`transform`: geometry_msgs/msg/TransformStamped on /mocap/wrist (child frame `wrist`);
`tf`: tf2_msgs/msg/TFMessage on /tf as a robot and a mocap bridge share it — the body (`world` ->
`wrist`) among other frames in the same messages, a robot's joints' frames in messages of their own
at another rate — and /tf_static holding `world` -> `mocap` once.
Stamps are `ns` exactly; each message is logged 2 ms after its stamp.
"""

import csv
import sys

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS2_HUMBLE)
Time = ts.types['builtin_interfaces/msg/Time']
Header = ts.types['std_msgs/msg/Header']
JointState = ts.types['sensor_msgs/msg/JointState']
Point = ts.types['geometry_msgs/msg/Point']
Vector3 = ts.types['geometry_msgs/msg/Vector3']
Quaternion = ts.types['geometry_msgs/msg/Quaternion']
Pose = ts.types['geometry_msgs/msg/Pose']
PoseStamped = ts.types['geometry_msgs/msg/PoseStamped']
Transform = ts.types['geometry_msgs/msg/Transform']
TransformStamped = ts.types['geometry_msgs/msg/TransformStamped']
TFMessage = ts.types['tf2_msgs/msg/TFMessage']

LOG_DELAY_NS = 2_000_000


def header(ns, frame):
    return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=frame)


def rows(path):
    with open(path, newline='') as f:
        return [[int(r[0])] + [float(v) for v in r[1:]] for r in csv.reader(f)]


def transform(ns, parent, child, x, y, z, qx, qy, qz, qw):
    return TransformStamped(
        header=header(ns, parent),
        child_frame_id=child,
        transform=Transform(translation=Vector3(x=x, y=y, z=z), rotation=Quaternion(x=qx, y=qy, z=qz, w=qw)),
    )


def main(mode, joints_path, body_path, out):
    import numpy as np

    messages = []  # (log ns, connection key, message, type)
    for ns, *theta in rows(joints_path):
        msg = JointState(
            header=header(ns, ''),
            name=['theta1', 'theta2', 'theta3'],
            position=np.array(theta, dtype=np.float64),
            velocity=np.array([], dtype=np.float64),
            effort=np.array([], dtype=np.float64),
        )
        messages.append((ns + LOG_DELAY_NS, 'joints', msg, JointState.__msgtype__))
    for k, (ns, x, y, z, qx, qy, qz, qw) in enumerate(rows(body_path)):
        if mode == 'pose':
            pose = Pose(position=Point(x=x, y=y, z=z), orientation=Quaternion(x=qx, y=qy, z=qz, w=qw))
            messages.append((ns + LOG_DELAY_NS, 'body', PoseStamped(header=header(ns, 'world'), pose=pose), PoseStamped.__msgtype__))
        elif mode == 'transform':
            msg = transform(ns, 'world', 'wrist', x, y, z, qx, qy, qz, qw)
            messages.append((ns + LOG_DELAY_NS, 'body', msg, TransformStamped.__msgtype__))
        else:
            # The bridge publishes every rigid body it tracks in one message, the wrist second.
            other = transform(ns, 'world', 'tool_tray', 0.3, -0.1, 0.02, 0.0, 0.0, 0.0, 1.0)
            wrist = transform(ns, 'world', 'wrist', x, y, z, qx, qy, qz, qw)
            messages.append((ns + LOG_DELAY_NS, 'body', TFMessage(transforms=[other, wrist]), TFMessage.__msgtype__))
            # The robot's own frames, stamped between the bodies', with stamps that go back
            # relative to the wrist's (tf mixes clocks; only the body's own must increase).
            robot = transform(ns - 1_000_000, 'base_link', 'link_%d' % (k % 3), 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 1.0)
            messages.append((ns + LOG_DELAY_NS + 1, 'body', TFMessage(transforms=[robot]), TFMessage.__msgtype__))
    if mode == 'tf':
        first = min(m[0] for m in messages)
        static = transform(first - LOG_DELAY_NS, 'world', 'mocap', 0.0, 0.0, 1.5, 0.0, 0.0, 0.0, 1.0)
        messages.append((first - 1, 'static', TFMessage(transforms=[static]), TFMessage.__msgtype__))
    messages.sort(key=lambda m: m[0])
    topics = {
        'joints': ('/joint_states', JointState.__msgtype__),
        'body': {
            'pose': ('/vrpn_mocap/wrist/pose', PoseStamped.__msgtype__),
            'transform': ('/mocap/wrist', TransformStamped.__msgtype__),
            'tf': ('/tf', TFMessage.__msgtype__),
        }[mode],
        'static': ('/tf_static', TFMessage.__msgtype__),
    }
    with Writer(out, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        connections = {}
        for log_ns, key, msg, typename in messages:
            if key not in connections:
                topic, msgtype = topics[key]
                connections[key] = w.add_connection(topic, msgtype, typestore=ts)
            w.write(connections[key], log_ns, ts.serialize_cdr(msg, typename))


if __name__ == '__main__':
    if len(sys.argv) != 5 or sys.argv[1] not in ('pose', 'transform', 'tf'):
        sys.exit(__doc__)
    main(*sys.argv[1:])
