"""The CDR bytes of the rigid-body messages as Python's `rosbags` (an independent writer) serialises
them: `geometry_msgs/msg/PoseStamped`, `geometry_msgs/msg/TransformStamped` and
`tf2_msgs/msg/TFMessage` (two transforms), little- and big-endian. Prints `type endian hex` lines;
`rosbags_cdr.txt` is its output, decoded by the unit tests of src/dataset/bag/messages.rs and
compared with a fresh run by tests/bags.rs where `rosbags` is installed.

    python3 tests/data/bags/rosbags_cdr.py > tests/data/bags/rosbags_cdr.txt
"""

from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS2_HUMBLE)
T = ts.types['builtin_interfaces/msg/Time']
H = ts.types['std_msgs/msg/Header']
P = ts.types['geometry_msgs/msg/Point']
V = ts.types['geometry_msgs/msg/Vector3']
Q = ts.types['geometry_msgs/msg/Quaternion']
POSE = ts.types['geometry_msgs/msg/Pose']
PS = ts.types['geometry_msgs/msg/PoseStamped']
TR = ts.types['geometry_msgs/msg/Transform']
TS = ts.types['geometry_msgs/msg/TransformStamped']
TF = ts.types['tf2_msgs/msg/TFMessage']

# Frame names of odd lengths so that the strings leave padding before the next float64.
pose = PS(
    header=H(stamp=T(sec=1700000000, nanosec=123456789), frame_id='world'),
    pose=POSE(position=P(x=0.125, y=-0.25, z=0.7), orientation=Q(x=0.1, y=-0.2, z=0.3, w=0.9273618495495704)),
)
transform = TS(
    header=H(stamp=T(sec=1700000001, nanosec=5), frame_id='mocap'),
    child_frame_id='wrist',
    transform=TR(translation=V(x=-0.03, y=0.04, z=0.65), rotation=Q(x=0.0, y=0.0, z=0.6, w=0.8)),
)
other = TS(
    header=H(stamp=T(sec=1700000001, nanosec=5), frame_id='world'),
    child_frame_id='base_link_x',
    transform=TR(translation=V(x=1.0, y=2.0, z=3.0), rotation=Q(x=0.0, y=0.0, z=0.0, w=1.0)),
)
tf = TF(transforms=[other, transform])

for name, msg, typename in [
    ('PoseStamped', pose, PS.__msgtype__),
    ('TransformStamped', transform, TS.__msgtype__),
    ('TFMessage', tf, TF.__msgtype__),
]:
    for little in [True, False]:
        data = bytes(ts.serialize_cdr(msg, typename, little_endian=little))
        print(name, 'le' if little else 'be', data.hex())
