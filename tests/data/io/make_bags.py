#!/usr/bin/python3
"""Writes the ROS 1 bags of the import tests with rosbag itself (Debian: python3-rosbag,
python3-geometry-msgs, python3-sensor-msgs, python3-tf2-msgs, python3-roslz4); run from this folder:
    /usr/bin/python3 make_bags.py
The trajectory is the other sample logs' (sample.csv): sample i = 0..19 at 2 kHz from t = 1.7e9 s,
position (10 + i, -5 + 0.5 i, 30) mm, a turn of 3 i degrees about z; a gripper closing from
0.8 rad to 0 (the jaw 1 - i / 19 with --jaw-range 0,0.8). Each message is recorded 0.2 ms after
its header stamp (a bag's record time is when it arrived).
  sample.bag, sample_bz2.bag, sample_lz4.bag: /psm/measured_cp (PoseStamped), /psm/jaw/measured_js
      (JointState), /psm/state (String); the same messages uncompressed, bz2 and lz4.
  topics.bag: /psm1/measured_cp (PoseStamped), /psm2/measured_cp (TransformStamped), /mtm/pose
      (Pose, no header), /mtm/gripper (Float64, no header), /tf (TFMessage: world -> psm1_base, a
      fixed shift, and psm1_base -> psm1_tool, the trajectory, in each message) and /tf_static
      (world -> camera, once), /psm1/joint_states (JointState: yaw, pitch, jaw; the gripper third),
      /touch/buttons (Joy: two buttons, the second pressed from sample 5 to 12, a message every
      other sample).
  tf_chain.bag: a tf tree whose stamps count from 100 s (not 1.7e9: the interpolation's times
      exact to ~1e-14 s): /tf_static world -> base (0.1, 0.2, 0.3) m and a quarter turn about z,
      once; /tf base -> arm at samples 2, 6, .., 22 (translation (0.01 k / 20, 0, 0.05) m and a turn
      of 2 k degrees about x at sample k: linear in time, so interpolation is exact), and
      "arm" -> "/tool" (tf1's leading slash) the trajectory at every sample; a frame "loose" with
      two parents (world and base) above "probe".
"""
import math

import rosbag
import rospy
from geometry_msgs.msg import Pose, PoseStamped, TransformStamped
from sensor_msgs.msg import JointState, Joy
from std_msgs.msg import Float64, String
from tf2_msgs.msg import TFMessage


def sample(i):
    t = rospy.Time(1700000000) + rospy.Duration.from_sec(5e-4 * i)
    p = ((10 + i) * 1e-3, (-5 + 0.5 * i) * 1e-3, 30e-3)
    a = math.radians(3.0 * i)
    q = (0.0, 0.0, math.sin(a / 2), math.cos(a / 2))  # x, y, z, w
    return t, p, q, 0.8 * (1 - i / 19.0)


def pose_stamped(t, p, q, frame="psm_base"):
    m = PoseStamped()
    m.header.stamp, m.header.frame_id = t, frame
    m.pose.position.x, m.pose.position.y, m.pose.position.z = p
    m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w = q
    return m


def write_sample(name, compression):
    with rosbag.Bag(name, "w", compression=compression) as bag:
        for i in range(20):
            t, p, q, jaw = sample(i)
            arrive = t + rospy.Duration.from_sec(2e-4)
            bag.write("/psm/measured_cp", pose_stamped(t, p, q), arrive)
            js = JointState()
            js.header.stamp, js.name, js.position = t, ["jaw"], [jaw]
            bag.write("/psm/jaw/measured_js", js, arrive)
            if i % 10 == 0:
                bag.write("/psm/state", String(data="ENABLED"), arrive)


def transform(t, parent, child, p, q):
    tf = TransformStamped()
    tf.header.stamp, tf.header.frame_id, tf.child_frame_id = t, parent, child
    tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z = p
    r = tf.transform.rotation
    r.x, r.y, r.z, r.w = q
    return tf


def write_topics(name):
    with rosbag.Bag(name, "w") as bag:
        t0 = sample(0)[0]
        bag.write("/tf_static", TFMessage(transforms=[transform(t0, "world", "camera", (0, 0, 1), (0, 0, 0, 1))]), t0)
        for i in range(20):
            t, p, q, jaw = sample(i)
            arrive = t + rospy.Duration.from_sec(2e-4)
            bag.write("/psm1/measured_cp", pose_stamped(t, p, q), arrive)
            bag.write("/psm2/measured_cp", transform(t, "world", "psm2_tool", p, q), arrive)
            base = transform(t, "world", "psm1_base", (0.1, 0, 0), (0, 0, 0, 1))
            bag.write("/tf", TFMessage(transforms=[base, transform(t, "psm1_base", "psm1_tool", p, q)]), arrive)
            pose = Pose()
            pose.position.x, pose.position.y, pose.position.z = p
            pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = q
            bag.write("/mtm/pose", pose, arrive)
            bag.write("/mtm/gripper", Float64(data=jaw), arrive)
            js = JointState()
            js.header.stamp, js.name, js.position = t, ["yaw", "pitch", "jaw"], [0.1 * i, -0.1 * i, jaw]
            bag.write("/psm1/joint_states", js, arrive)
            if i % 2 == 1:
                joy = Joy()
                joy.header.stamp, joy.axes, joy.buttons = t, [0.0], [0, 1 if 5 <= i <= 12 else 0]
                bag.write("/touch/buttons", joy, arrive)


def write_chain(name):
    start = rospy.Time(100)
    at = lambda i: start + rospy.Duration.from_sec(5e-4 * i)
    with rosbag.Bag(name, "w") as bag:
        quarter = (0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4))
        bag.write("/tf_static", TFMessage(transforms=[transform(at(0), "world", "base", (0.1, 0.2, 0.3), quarter)]), at(0))
        for i in range(23):
            if i % 4 == 2:
                a = math.radians(2.0 * i)
                arm = transform(at(i), "base", "arm", (0.01 * i / 20, 0, 0.05), (math.sin(a / 2), 0, 0, math.cos(a / 2)))
                bag.write("/tf", TFMessage(transforms=[arm]), at(i))
            if i < 20:
                _, p, q, _ = sample(i)
                loose = [transform(at(i), "world" if i % 2 == 0 else "base", "loose", (0, 0, 0), (0, 0, 0, 1)),
                         transform(at(i), "loose", "probe", p, q)]
                bag.write("/tf", TFMessage(transforms=[transform(at(i), "arm", "/tool", p, q)] + loose), at(i))


write_sample("sample.bag", "none")
write_sample("sample_bz2.bag", "bz2")
write_sample("sample_lz4.bag", "lz4")
write_topics("topics.bag")
write_chain("tf_chain.bag")
