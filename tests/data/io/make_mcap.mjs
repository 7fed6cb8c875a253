// Writes the ROS 2 bags (MCAP) of the import tests with the MCAP reference library (npm:
// @mcap/core, @foxglove/rosmsg, @foxglove/rosmsg2-serialization, @foxglove/wasm-zstd), as
// rosbag2's MCAP storage writes them: ros2msg schemas, CDR messages, chunks. Run from this folder
// with those packages installed (npm install ...):  node make_mcap.mjs
// The content is make_bags.py's sample.bag: /psm/measured_cp (PoseStamped), /psm/jaw/measured_js
// (JointState), /psm/state (String), with /tf (TFMessage: world -> psm1_base, psm1_base ->
// psm1_tool, the trajectory) and /touch/buttons (Joy) as in topics.bag; each message logged 0.2 ms
// after its stamp.
//   sample.mcap: zstd chunks (rosbag2's default); sample_none.mcap: uncompressed chunks.
import { McapWriter } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import * as zstd from "@foxglove/wasm-zstd";
import { open } from "node:fs/promises";

const SEP = "\n================================================================================\n";
const header = "builtin_interfaces/Time stamp\nstring frame_id";
const time = "int32 sec\nuint32 nanosec";
const point = "float64 x\nfloat64 y\nfloat64 z";
const quat = "float64 x\nfloat64 y\nfloat64 z\nfloat64 w";
const deps = {
  header: `MSG: std_msgs/Header\n${header}${SEP}MSG: builtin_interfaces/Time\n${time}`,
  pose: `MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation${SEP}MSG: geometry_msgs/Point\n${point}${SEP}MSG: geometry_msgs/Quaternion\n${quat}`,
  transform: `MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation${SEP}MSG: geometry_msgs/Vector3\n${point}${SEP}MSG: geometry_msgs/Quaternion\n${quat}`,
};
const transformStamped = `std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform`;
const types = {
  "geometry_msgs/msg/PoseStamped": `std_msgs/Header header\ngeometry_msgs/Pose pose${SEP}${deps.header}${SEP}${deps.pose}`,
  "sensor_msgs/msg/JointState": `std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort${SEP}${deps.header}`,
  "std_msgs/msg/String": "string data",
  "sensor_msgs/msg/Joy": `std_msgs/Header header\nfloat32[] axes\nint32[] buttons${SEP}${deps.header}`,
  "tf2_msgs/msg/TFMessage": `geometry_msgs/TransformStamped[] transforms${SEP}MSG: geometry_msgs/TransformStamped\n${transformStamped}${SEP}${deps.header}${SEP}${deps.transform}`,
};

function sample(i) {
  const ns = 1700000000n * 1000000000n + BigInt(i) * 500000n;
  const a = (3.0 * i * Math.PI) / 180;
  return {
    ns,
    stamp: { sec: 1700000000, nanosec: i * 500000 },
    p: { x: (10 + i) * 1e-3, y: (-5 + 0.5 * i) * 1e-3, z: 30e-3 },
    q: { x: 0, y: 0, z: Math.sin(a / 2), w: Math.cos(a / 2) },
    jaw: 0.8 * (1 - i / 19.0),
  };
}

async function write(name, compress) {
  const file = await open(name, "w");
  let position = 0n;
  const writable = {
    position: () => position,
    write: async (buffer) => {
      await file.write(buffer);
      position += BigInt(buffer.byteLength);
    },
  };
  const writer = new McapWriter({ writable, useChunks: true, compressChunk: compress });
  await writer.start({ profile: "ros2", library: "make_mcap.mjs" });
  const channels = {}, writers = {};
  for (const [topic, type] of [["/psm/measured_cp", "geometry_msgs/msg/PoseStamped"],
                               ["/psm/jaw/measured_js", "sensor_msgs/msg/JointState"],
                               ["/psm/state", "std_msgs/msg/String"], ["/tf", "tf2_msgs/msg/TFMessage"],
                               ["/touch/buttons", "sensor_msgs/msg/Joy"]]) {
    const schemaId = await writer.registerSchema({ name: type, encoding: "ros2msg", data: new TextEncoder().encode(types[type]) });
    channels[topic] = await writer.registerChannel({ topic, schemaId, messageEncoding: "cdr", metadata: new Map() });
    writers[topic] = new MessageWriter(parse(types[type], { ros2: true }));
  }
  let sequence = 0;
  const add = async (topic, logNs, message) =>
    writer.addMessage({ channelId: channels[topic], sequence: sequence++, logTime: logNs, publishTime: logNs,
                        data: writers[topic].writeMessage(message) });
  for (let i = 0; i < 20; ++i) {
    const s = sample(i), arrive = s.ns + 200000n;
    const hdr = (frame_id) => ({ stamp: s.stamp, frame_id });
    await add("/psm/measured_cp", arrive, { header: hdr("psm_base"), pose: { position: s.p, orientation: s.q } });
    await add("/psm/jaw/measured_js", arrive, { header: hdr(""), name: ["jaw"], position: [s.jaw], velocity: [], effort: [] });
    if (i % 10 === 0) await add("/psm/state", arrive, { data: "ENABLED" });
    if (i % 2 === 1)
      await add("/touch/buttons", arrive, { header: hdr(""), axes: [0.0], buttons: [0, i >= 5 && i <= 12 ? 1 : 0] });
    await add("/tf", arrive, { transforms: [
      { header: hdr("world"), child_frame_id: "psm1_base", transform: { translation: { x: 0.1, y: 0, z: 0 }, rotation: { x: 0, y: 0, z: 0, w: 1 } } },
      { header: hdr("psm1_base"), child_frame_id: "psm1_tool", transform: { translation: s.p, rotation: s.q } },
    ] });
  }
  await writer.end();
  await file.close();
}

await zstd.isLoaded;
await write("sample.mcap", (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }));
await write("sample_none.mcap", (data) => ({ compression: "", compressedData: data }));
