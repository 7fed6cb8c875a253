// ROS bags: ROS 1's format 2.0 and ROS 2's MCAP (io/rosbag.hpp).
#include "io/rosbag.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "math/vec.hpp"

#if EBH_HAVE_BZIP2
#include <bzlib.h>
#endif
#if EBH_HAVE_LZ4
#include <lz4frame.h>
#endif
#if EBH_HAVE_ZSTD
#include <zstd.h>
#endif

namespace ebh {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = sizeof kMagic - 1;
/// A chunk larger than this (uncompressed) is refused before it is allocated (`rosbag record`
/// writes chunks of 768 KB unless --chunksize says otherwise).
constexpr std::uint64_t kMaxChunkBytes = std::uint64_t(1) << 30;

// The record ops of format 2.0.
constexpr std::uint8_t kOpMessage = 0x02, kOpBagHeader = 0x03, kOpIndex = 0x04, kOpChunk = 0x05, kOpChunkInfo = 0x06,
                       kOpConnection = 0x07;

/// What a known message type gives: a pose, a tf message's poses (a list of TransformStamped to
/// several frames), the jaw, the buttons.
enum class Role { pose, tf, jaw, buttons };

struct KnownType {
  const char* name;
  const char* md5;
  Role role;
};
// The types read, with the MD5 sums of their definitions (as genpy gives them: Type._md5sum).
constexpr KnownType kKnownTypes[] = {
    {"geometry_msgs/PoseStamped", "d3812c3cbc69362b77dc0b19b345f8f5", Role::pose},
    {"geometry_msgs/TransformStamped", "b5764a33bfeb3588febc2682852579b0", Role::pose},
    {"geometry_msgs/Pose", "e45d45a5a1ce597b249e23fb30fc871f", Role::pose},
    {"geometry_msgs/Transform", "ac9eff44abf714214112b05d54a3cf9b", Role::pose},
    {"tf2_msgs/TFMessage", "94810edda583a504dfda3829e70d7eec", Role::tf},
    {"tf/tfMessage", "94810edda583a504dfda3829e70d7eec", Role::tf},
    {"sensor_msgs/JointState", "3066dcd76a6cfaef579bd0f34173e9fd", Role::jaw},
    {"std_msgs/Float64", "fdb28210bfa9d7c91146260178d9a584", Role::jaw},
    {"std_msgs/Float32", "73fcbf46b49191e672908e50842a83d4", Role::jaw},
    {"sensor_msgs/Joy", "5a9ea5f83505693b71e785041e67a8bb", Role::buttons},
};

const KnownType* known_type(const std::string& type) {
  for (const KnownType& k : kKnownTypes)
    if (type == k.name) return &k;
  return nullptr;
}

std::uint32_t u32(const unsigned char* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}

std::uint64_t u64(const unsigned char* p) { return std::uint64_t(u32(p)) | std::uint64_t(u32(p + 4)) << 32; }

// MCAP (ROS 2's default bag storage): its magic and the record opcodes read.
constexpr char kMcapMagic[] = "\x89MCAP0\r\n";
constexpr std::size_t kMcapMagicSize = 8;
constexpr std::uint8_t kMcapFooter = 0x02, kMcapSchema = 0x03, kMcapChannel = 0x04, kMcapMessage = 0x05, kMcapChunk = 0x06,
                       kMcapDataEnd = 0x0f;

/// An MCAP record's fields, read in order (little-endian; strings with a uint32 length).
struct McapFields {
  const unsigned char* p;
  std::size_t n, pos = 0;
  const std::string& where;
  void need(std::uint64_t k) const {
    if (k > n - pos) throw InputError(where + ": a field overruns its record (" + std::to_string(n) + " bytes)");
  }
  std::uint16_t u16() {
    need(2);
    pos += 2;
    return static_cast<std::uint16_t>(p[pos - 2] | p[pos - 1] << 8);
  }
  std::uint32_t u32() {
    need(4);
    pos += 4;
    return ebh::u32(p + pos - 4);
  }
  std::uint64_t u64() {
    need(8);
    pos += 8;
    return ebh::u64(p + pos - 8);
  }
  std::string string() {
    const std::uint32_t len = u32();
    need(len);
    pos += len;
    return std::string(reinterpret_cast<const char*>(p + pos - len), len);
  }
};

/// A record's header fields (name=value, the value raw bytes), or a connection record's data.
using Fields = std::map<std::string, std::string>;

Fields parse_fields(const unsigned char* p, std::size_t n, const std::string& where) {
  Fields f;
  std::size_t pos = 0;
  while (pos < n) {
    if (n - pos < 4) throw InputError(where + ": a header field's length is cut short");
    const std::uint32_t len = u32(p + pos);
    pos += 4;
    if (len > n - pos) throw InputError(where + ": a header field of " + std::to_string(len) + " bytes overruns its header");
    const auto* b = reinterpret_cast<const char*>(p + pos);
    const auto* eq = static_cast<const char*>(std::memchr(b, '=', len));
    if (!eq) throw InputError(where + ": a header field without '=' (name=value)");
    f.emplace(std::string(b, eq), std::string(eq + 1, b + len));
    pos += len;
  }
  return f;
}

const std::string& field(const Fields& f, const char* name, const std::string& where) {
  const auto it = f.find(name);
  if (it == f.end()) throw InputError(where + ": the record has no '" + name + "' field");
  return it->second;
}

std::uint32_t field_u32(const Fields& f, const char* name, const std::string& where) {
  const std::string& v = field(f, name, where);
  if (v.size() != 4) throw InputError(where + ": field '" + name + "' holds " + std::to_string(v.size()) + " bytes, not 4");
  return u32(reinterpret_cast<const unsigned char*>(v.data()));
}

/// A ROS time (uint32 seconds, uint32 nanoseconds) in seconds.
double ros_time(const unsigned char* p) { return u32(p) + 1e-9 * u32(p + 4); }

/// A message's bytes, read in order: ROS 1's serialisation (little-endian, strings and arrays
/// with a uint32 count before them, nothing aligned) or ROS 2's CDR (the same, after a 4-byte
/// encapsulation header, each number aligned to its size from the payload's start, strings with
/// a closing NUL in their count, a Header without seq).
struct MessageCursor {
  const unsigned char* p;
  std::size_t n, pos = 0;
  const std::string& where;
  bool cdr = false;
  void need(std::size_t k, const char* what) const {
    if (k > n - pos)
      throw InputError(where + ": the message ends (" + std::to_string(n) + " bytes) inside its " + what);
  }
  void align(std::size_t k) {
    if (cdr) pos = std::min(n, (pos + k - 1) / k * k);
  }
  std::uint32_t u32(const char* what) {
    align(4);
    need(4, what);
    pos += 4;
    return ebh::u32(p + pos - 4);
  }
  std::uint32_t count(const char* what) { return u32(what); }
  std::string string(const char* what) {
    const std::uint32_t len = count(what);
    need(len, what);
    pos += len;
    std::string text(reinterpret_cast<const char*>(p + pos - len), len);
    if (cdr && !text.empty() && text.back() == '\0') text.pop_back();
    return text;
  }
  void skip_string(const char* what) { (void)string(what); }
  double f64(const char* what) {
    align(8);
    need(8, what);
    double v;
    std::memcpy(&v, p + pos, 8);  // little-endian, as x86 and ARM
    pos += 8;
    return v;
  }
  float f32(const char* what) {
    align(4);
    need(4, what);
    float v;
    std::memcpy(&v, p + pos, 4);
    pos += 4;
    return v;
  }
  /// std_msgs/Header: (ROS 1: seq,) stamp, frame_id; returns the stamp (s), the frame into `frame_id`.
  double header(std::string* frame_id = nullptr) {
    const std::size_t seq = cdr ? 0 : 4;
    align(4);
    need(seq + 8, "header");
    const double stamp = ros_time(p + pos + seq);
    pos += seq + 8;
    std::string frame = string("header's frame_id");
    if (frame_id) *frame_id = std::move(frame);
    return stamp;
  }
  Vec3d vec3(const char* what) {
    const double x = f64(what), y = f64(what), z = f64(what);
    return {x, y, z};
  }
  Quatd quat(const char* what) {
    const double x = f64(what), y = f64(what), z = f64(what), w = f64(what);
    return {w, x, y, z};
  }
};

/// The cursor over a message of `encoding` (ros1, or cdr: its encapsulation header checked).
MessageCursor cursor(const unsigned char* p, std::size_t n, const std::string& where, bool cdr) {
  if (!cdr) return MessageCursor{p, n, 0, where, false};
  if (n < 4) throw InputError(where + ": the message ends (" + std::to_string(n) + " bytes) inside its CDR header");
  if (p[0] != 0 || (p[1] != 1 && p[1] != 0))
    throw InputError(where + ": a CDR encapsulation of kind " + std::to_string(p[1]) + " (a ROS 2 message is plain CDR)");
  if (p[1] == 0) throw InputError(where + ": a big-endian CDR message (only little-endian ones are read)");
  return MessageCursor{p + 4, n - 4, 0, where, true};
}

BagPose decode_pose(const std::string& type, const unsigned char* p, std::size_t n, const std::string& where, bool cdr) {
  MessageCursor c = cursor(p, n, where, cdr);
  BagPose m;
  if (type == "geometry_msgs/PoseStamped" || type == "geometry_msgs/TransformStamped") m.t.stamp = c.header();
  if (type == "geometry_msgs/TransformStamped") c.skip_string("child_frame_id");
  const char* what = type.find("Transform") != std::string::npos ? "transform" : "pose";
  m.position = c.vec3(what);
  m.orientation = c.quat(what);
  return m;
}

/// A tf message's transforms: each one's parent and child frames and its pose (stamp, translation,
/// rotation) to `each(parent, child, pose)`.
template <class Each>
void decode_tf(const unsigned char* p, std::size_t n, const std::string& where, bool cdr, Each&& each) {
  MessageCursor c = cursor(p, n, where, cdr);
  const std::uint32_t count = c.count("transforms");
  for (std::uint32_t i = 0; i < count; ++i) {  // each at least 80 bytes: the cursor ends a false count
    BagPose m;
    std::string parent;
    m.t.stamp = c.header(&parent);
    const std::string child = c.string("child_frame_id");
    m.position = c.vec3("transform");
    m.orientation = c.quat("transform");
    each(parent, child, m);
  }
}

/// A sensor_msgs/Joy's buttons: button i pressed (nonzero) sets bit i (i < 31; the others are
/// refused: a recording's buttons are one int).
BagButtons decode_buttons(const unsigned char* p, std::size_t n, const std::string& where, bool cdr) {
  MessageCursor c = cursor(p, n, where, cdr);
  BagButtons m;
  m.t.stamp = c.header();
  const std::uint32_t axes = c.count("axes");
  for (std::uint32_t i = 0; i < axes; ++i) (void)c.f32("axes");
  const std::uint32_t buttons = c.count("buttons");
  for (std::uint32_t i = 0; i < buttons; ++i) {
    const bool pressed = c.u32("buttons") != 0;
    if (pressed && i >= 31)
      throw InputError(where + ": button " + std::to_string(i) + " pressed (a recording holds buttons 0 to 30)");
    if (pressed) m.bits |= 1 << i;
  }
  return m;
}

/// A jaw message's value: a JointState's position of `joint` (empty: its first), or the number.
BagJaw decode_jaw(const std::string& type, const std::string& joint, const unsigned char* p, std::size_t n,
                  const std::string& where, bool cdr) {
  MessageCursor c = cursor(p, n, where, cdr);
  BagJaw m;
  if (type == "sensor_msgs/JointState") {
    m.t.stamp = c.header();
    const std::uint32_t names = c.count("joint names");
    std::uint32_t at = 0;
    std::string listed;  // the joints' names, for the error
    bool found = joint.empty();
    for (std::uint32_t i = 0; i < names; ++i) {
      const std::string name = c.string("joint names");
      if (!found && name == joint) {
        at = i;
        found = true;
      }
      if (listed.size() < 200) listed += (i ? ", " : "") + name;
    }
    if (!found)
      throw InputError(where + ": --jaw-joint " + joint + ": the joint state names no such joint (its joints: " +
                       (listed.empty() ? std::string("none") : listed) + ")");
    const std::uint32_t positions = c.count("positions");
    if (positions <= at)
      throw InputError(where + ": the joint state has " + std::to_string(positions) + " positions" +
                       (joint.empty() ? std::string() : ", none for joint " + joint));
    for (std::uint32_t i = 0; i < at; ++i) (void)c.f64("positions");
    m.value = c.f64("positions");
  } else if (type == "std_msgs/Float64") {
    m.value = c.f64("data");
  } else {
    m.value = c.f32("data");
  }
  return m;
}

/// A chunk compressed with a codec this build lacks (the libraries are optional: CMake says which it found).
[[maybe_unused]] InputError no_codec(const std::string& where, const std::string& codec, const std::string& package) {
  return InputError(where + ": a " + codec + "-compressed chunk, and this build of ebh has no " + codec + " library (" +
                    package + "): decompress the bag (rosbag decompress, mcap decompress) or rebuild with it");
}

/// A chunk's records, decompressed into `out` (bytes of the uncompressed size the chunk names).
void decompress_chunk(const std::string& compression, const unsigned char* data, std::size_t size, std::uint32_t out_size,
                      std::vector<unsigned char>& out, const std::string& where) {
  if (out_size > kMaxChunkBytes)
    throw InputError(where + ": a chunk of " + std::to_string(out_size) + " bytes (more than 1 GiB)");
  if (compression == "none") {
    if (size != out_size)
      throw InputError(where + ": an uncompressed chunk of " + std::to_string(size) + " bytes that names " +
                       std::to_string(out_size));
    out.assign(data, data + size);
    return;
  }
  // The output grows with what the stream gives (a damaged size field allocates nothing), up
  // to the size the chunk names.
  std::size_t produced = 0;
  [[maybe_unused]] const auto room = [&]() -> std::size_t {
    if (produced == out.size()) out.resize(produced + std::min<std::size_t>(out_size - produced, std::size_t(1) << 20));
    return out.size() - produced;
  };
  [[maybe_unused]] const auto wrong_size = [&](const char* codec) {
    return InputError(where + ": a" + std::string(codec) + " chunk that does not decompress to the " +
                      std::to_string(out_size) + " bytes it names");
  };
  out.clear();
  if (compression == "bz2") {
#if EBH_HAVE_BZIP2
    bz_stream z{};
    if (BZ2_bzDecompressInit(&z, 0, 0) != BZ_OK) throw std::bad_alloc();
    z.next_in = const_cast<char*>(reinterpret_cast<const char*>(data));
    z.avail_in = static_cast<unsigned int>(size);
    int rc = BZ_OK;
    while (rc == BZ_OK) {
      const std::size_t free = room();
      if (free == 0) break;  // full, and the stream goes on
      z.next_out = reinterpret_cast<char*>(out.data() + produced);
      z.avail_out = static_cast<unsigned int>(free);
      rc = BZ2_bzDecompress(&z);
      produced += free - z.avail_out;
      if (rc == BZ_OK && z.avail_in == 0 && z.avail_out != 0) break;  // the input ended before the stream
    }
    BZ2_bzDecompressEnd(&z);
    if (rc != BZ_STREAM_END || produced != out_size) throw wrong_size(" bz2");
    return;
#else
    throw no_codec(where, "bz2", "libbz2-dev");
#endif
  }
  if (compression == "lz4") {
#if EBH_HAVE_LZ4
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) throw std::bad_alloc();
    std::size_t in_pos = 0, hint = 1;
    while (hint != 0 && in_pos < size) {
      const std::size_t free = room();
      if (free == 0) break;  // full, and the frame goes on
      std::size_t in_n = size - in_pos, out_n = free;
      hint = LZ4F_decompress(ctx, out.data() + produced, &out_n, data + in_pos, &in_n, nullptr);
      if (LZ4F_isError(hint)) {
        const std::string name = LZ4F_getErrorName(hint);
        LZ4F_freeDecompressionContext(ctx);
        throw InputError(where + ": an lz4 chunk that does not decompress (" + name + ")");
      }
      in_pos += in_n;
      produced += out_n;
      if (in_n == 0 && out_n == 0) break;  // no progress
    }
    LZ4F_freeDecompressionContext(ctx);
    if (hint != 0 || produced != out_size) throw wrong_size("n lz4");
    return;
#else
    throw no_codec(where, "lz4", "liblz4-dev");
#endif
  }
  if (compression == "zstd") {
#if EBH_HAVE_ZSTD
    ZSTD_DStream* z = ZSTD_createDStream();
    if (!z) throw std::bad_alloc();
    ZSTD_inBuffer input{data, size, 0};
    std::size_t rc = 1;
    while (rc != 0) {
      const std::size_t free = room();
      if (free == 0) break;  // full, and the frame goes on
      ZSTD_outBuffer output{out.data() + produced, free, 0};
      rc = ZSTD_decompressStream(z, &output, &input);
      produced += output.pos;
      if (ZSTD_isError(rc)) {
        const std::string name = ZSTD_getErrorName(rc);
        ZSTD_freeDStream(z);
        throw InputError(where + ": a zstd chunk that does not decompress (" + name + ")");
      }
      if (input.pos == input.size && output.pos == 0) break;  // no progress: the input ended
    }
    ZSTD_freeDStream(z);
    if (rc != 0 || produced != out_size) throw wrong_size(" zstd");
    return;
#else
    throw no_codec(where, "zstd", "libzstd-dev");
#endif
  }
  throw InputError(where + ": a chunk compressed as '" + compression + "' (ROS bags use none, bz2, lz4 or zstd)");
}

/// What the reader keeps of a connection.
struct Connection {
  std::string topic, type;
  bool pose = false, jaw = false;  // of the requested (or a candidate) pose topic, of the jaw topic
  bool tf = false;                 // a tf topic (its transforms to the requested frame are the poses)
  bool cdr = false;                // ROS 2's serialisation (MCAP), else ROS 1's
  bool buttons = false;            // of the button topic
  bool tf_static = false;          // a tf topic of static transforms (its name ends in tf_static)
  std::size_t topic_index = 0;     // its entry in BagContents::topics
};

/// A tf frame id as tf2 compares them: without a leading '/' (tf1's "/world").
std::string frame_id(const std::string& id) { return !id.empty() && id[0] == '/' ? id.substr(1) : id; }

/// The time a tf lookup of `t` uses: the header stamp, or the record time where it is 0.
double lookup_time(const BagTimes& t) { return t.stamp > 0 ? t.stamp : t.record; }

/// The transforms of one tf link (parent -> child) read so far.
struct TfLink {
  std::string parent;
  std::string other_parent;       // a second parent seen for the child (a broken tree), else empty
  bool dynamic = false;           // some transform came from a topic other than tf_static
  std::vector<BagPose> transforms;
};

/// `outer` after `inner`: a pose in inner's parent frame given inner in outer's child frame.
BagPose compose(const BagPose& outer, const BagPose& inner) {
  BagPose r = inner;
  r.position = outer.position + rotate(outer.orientation, inner.position);
  r.orientation = outer.orientation * inner.orientation;
  return r;
}

class BagReader {
 public:
  BagReader(const std::string& path, const BagRequest& request)
      : path_(path),
        pose_topic_(request.pose_topic),
        jaw_topic_(request.jaw_topic),
        frame_(frame_id(request.frame)),
        jaw_joint_(request.jaw_joint),
        button_topic_(request.button_topic),
        root_frame_(frame_id(request.root_frame)) {}

  BagContents read() {
    std::ifstream in(path_, std::ios::binary | std::ios::ate);
    if (!in) throw InputError(path_ + ": cannot open the bag");
    const std::size_t size = static_cast<std::size_t>(in.tellg());
    in.seekg(0);
    char head[16] = {};
    in.read(head, std::min<std::size_t>(size, sizeof head));
    const std::string start(head, std::min<std::size_t>(size, sizeof head));
    if (start.compare(0, kMcapMagicSize, kMcapMagic, kMcapMagicSize) == 0) {
      contents_.kind = "ROS 2 bag (MCAP)";
      read_mcap(in, size);
      return finish();
    }
    if (start.compare(0, kMagicSize, kMagic) != 0) {
      if (start.rfind("#ROSRECORD V1.", 0) == 0 || start.rfind("#ROSBAG V1.", 0) == 0)
        throw InputError(path_ + ": a ROS bag of format 1.x: only format 2.0 (ROS since 2010) is read; play and "
                         "record it again with a current ROS 1");
      if (start.rfind("SQLite format 3", 0) == 0)
        throw InputError(path_ + ": a ROS 2 bag in sqlite3 (.db3): only MCAP ROS 2 bags are read; convert it "
                         "(ros2 bag convert, storage_id mcap) or export the pose topic to CSV (ros2 topic echo --csv)");
      throw InputError(path_ + ": not a ROS bag (it starts neither with \"#ROSBAG V2.0\" nor with MCAP's magic)");
    }
    contents_.kind = "ROS 1 bag";
    // The file's records, each read whole (a chunk is at most kMaxChunkBytes): a bag of camera
    // topics may be far larger than memory.
    std::size_t pos = kMagicSize;
    in.seekg(static_cast<std::streamoff>(pos));
    std::vector<unsigned char> header, body;
    auto read_u32 = [&](std::uint32_t& v) {
      unsigned char b[4];
      in.read(reinterpret_cast<char*>(b), 4);
      v = u32(b);
    };
    while (pos < size) {
      const std::string where = at_byte(pos);
      std::uint32_t header_len = 0, data_len = 0;
      if (size - pos < 4) break;
      read_u32(header_len);
      if (header_len > size - pos - 4) break;
      if (header_len > kMaxChunkBytes)
        throw InputError(where + ": a record header of " + std::to_string(header_len) + " bytes (more than 1 GiB)");
      header.resize(header_len);
      in.read(reinterpret_cast<char*>(header.data()), header_len);
      if (size - pos - 4 - header_len < 4) break;
      read_u32(data_len);
      if (data_len > size - pos - 8 - header_len) break;
      if (data_len > kMaxChunkBytes)
        throw InputError(where + ": a record of " + std::to_string(data_len) + " bytes (more than 1 GiB)");
      body.resize(data_len);
      in.read(reinterpret_cast<char*>(body.data()), data_len);
      if (!in) throw InputError(where + ": the bag cannot be read here");
      record(header.data(), header_len, body.data(), data_len, where, true, pos);
      pos += 8 + std::size_t(header_len) + data_len;
    }
    contents_.cut_bytes = size - pos;  // a recording stopped mid-write: its last record is left out
    return finish();
  }

 private:
  std::string at_byte(std::size_t offset) const { return path_ + ": byte " + std::to_string(offset); }

  /// The records of a chunk (its record at byte `chunk_at` of the file).
  void chunk_records(const std::vector<unsigned char>& data, std::size_t chunk_at) {
    std::size_t pos = 0;
    const std::size_t size = data.size();
    while (pos < size) {
      const std::string where = at_byte(chunk_at) + " (a chunk), its byte " + std::to_string(pos);
      if (size - pos < 4) throw InputError(where + ": a record's header length overruns the chunk");
      const std::uint32_t header_len = u32(data.data() + pos);
      if (header_len > size - pos - 4) throw InputError(where + ": a record's header overruns the chunk");
      const std::size_t body_at = pos + 4 + header_len;
      if (size - body_at < 4) throw InputError(where + ": a record's data length overruns the chunk");
      const std::uint32_t data_len = u32(data.data() + body_at);
      if (data_len > size - body_at - 4) throw InputError(where + ": a record's data overruns the chunk");
      record(data.data() + pos + 4, header_len, data.data() + body_at + 4, data_len, where, false, chunk_at);
      pos = body_at + 4 + data_len;
    }
  }

  /// One record: its header fields and its data (`top`: of the file, not of a chunk).
  void record(const unsigned char* header, std::size_t header_len, const unsigned char* body, std::size_t data_len,
              const std::string& where, bool top, std::size_t at) {
    const Fields f = parse_fields(header, header_len, where);
    const std::string& op = field(f, "op", where);
    if (op.size() != 1) throw InputError(where + ": a record's op of " + std::to_string(op.size()) + " bytes");
    switch (static_cast<std::uint8_t>(op[0])) {
      case kOpChunk: {
        if (!top) throw InputError(where + ": a chunk inside a chunk");
        decompress_chunk(field(f, "compression", where), body, data_len, field_u32(f, "size", where), chunk_, where);
        chunk_records(chunk_, at);
        break;
      }
      case kOpConnection: connection(f, body, data_len, where); break;
      case kOpMessage: message(f, body, data_len, where); break;
      case kOpBagHeader: case kOpIndex: case kOpChunkInfo: break;
      default:
        throw InputError(where + ": a record of op " + std::to_string(static_cast<int>(static_cast<unsigned char>(op[0]))) +
                         " (format 2.0 has ops 2 to 7)");
    }
  }

  /// An MCAP file's data section (mcap.dev/spec): its Schema, Channel and Message records, and those
  /// of its chunks, up to DataEnd or the Footer (the summary after them repeats what is read). A
  /// record cut short at the end is left out, as a ROS 1 bag's.
  void read_mcap(std::ifstream& in, std::size_t size) {
    std::size_t pos = kMcapMagicSize;
    in.seekg(static_cast<std::streamoff>(pos));
    std::vector<unsigned char> body;
    while (pos < size) {
      const std::string where = at_byte(pos);
      unsigned char head[9];
      if (size - pos < 9) break;
      in.read(reinterpret_cast<char*>(head), 9);
      const std::uint8_t op = head[0];
      const std::uint64_t len = u64(head + 1);
      if (len > size - pos - 9) break;
      if (op == kMcapDataEnd || op == kMcapFooter) {
        pos = size;
        break;
      }
      if (op == kMcapSchema || op == kMcapChannel || op == kMcapMessage || op == kMcapChunk) {
        if (len > kMaxChunkBytes)
          throw InputError(where + ": a record of " + std::to_string(len) + " bytes (more than 1 GiB)");
        body.resize(len);
        in.read(reinterpret_cast<char*>(body.data()), static_cast<std::streamsize>(len));
        if (!in) throw InputError(where + ": the bag cannot be read here");
        mcap_record(op, body.data(), len, where, true, pos);
      } else {  // attachments, indexes, metadata: not needed
        in.seekg(static_cast<std::streamoff>(len), std::ios::cur);
      }
      pos += 9 + len;
    }
    contents_.cut_bytes = size - pos;
  }

  /// One MCAP record of the data section (`top`) or of a chunk.
  void mcap_record(std::uint8_t op, const unsigned char* p, std::size_t n, const std::string& where, bool top,
                   std::size_t at) {
    McapFields f{p, n, 0, where};
    switch (op) {
      case kMcapSchema: {
        const std::uint16_t id = f.u16();
        std::string name = f.string(), encoding = f.string();
        schemas_[id] = encoding == "ros2msg" || encoding == "ros2idl" ? name : "(" + encoding + ") " + name;
        break;
      }
      case kMcapChannel: {
        const std::uint16_t id = f.u16(), schema = f.u16();
        const std::string topic = f.string(), encoding = f.string();
        if (connections_.count(id)) break;  // a chunk may repeat its channels
        const auto type = schemas_.find(schema);
        if (type == schemas_.end())
          throw InputError(where + ": channel " + topic + " names schema " + std::to_string(schema) + " before it");
        // A message encoding other than ROS 2's CDR: its type is not one read here.
        add_connection(id, topic, encoding == "cdr" ? type->second : "(" + encoding + ") " + type->second, "*", true, where);
        break;
      }
      case kMcapMessage: {
        const std::uint16_t channel = f.u16();
        (void)f.u32();  // sequence
        const std::uint64_t log_ns = f.u64();
        (void)f.u64();  // publish time
        on_message(channel, static_cast<double>(log_ns / 1000000000u) + 1e-9 * static_cast<double>(log_ns % 1000000000u),
                   p + f.pos, n - f.pos, where);
        break;
      }
      case kMcapChunk: {
        if (!top) throw InputError(where + ": a chunk inside a chunk");
        (void)f.u64();  // the messages' first and last log times
        (void)f.u64();
        const std::uint64_t out_size = f.u64();
        (void)f.u32();  // CRC
        const std::string compression = f.string();
        const std::uint64_t records = f.u64();
        f.need(records);
        if (out_size > kMaxChunkBytes)
          throw InputError(where + ": a chunk of " + std::to_string(out_size) + " bytes (more than 1 GiB)");
        decompress_chunk(compression.empty() ? "none" : compression, p + f.pos, records,
                         static_cast<std::uint32_t>(out_size), chunk_, where);
        std::size_t pos = 0;
        while (pos < chunk_.size()) {
          const std::string inner = at_byte(at) + " (a chunk), its byte " + std::to_string(pos);
          if (chunk_.size() - pos < 9) throw InputError(inner + ": a record's opcode and length overrun the chunk");
          const std::uint64_t len = u64(chunk_.data() + pos + 1);
          if (len > chunk_.size() - pos - 9) throw InputError(inner + ": a record's content overruns the chunk");
          const std::uint8_t inner_op = chunk_[pos];
          if (inner_op == kMcapSchema || inner_op == kMcapChannel || inner_op == kMcapMessage)
            mcap_record(inner_op, chunk_.data() + pos + 9, len, inner, false, at);
          pos += 9 + len;
        }
        break;
      }
      default: break;
    }
  }

  /// A ROS 1 connection record.
  void connection(const Fields& f, const unsigned char* body, std::size_t n, const std::string& where) {
    const std::uint32_t id = field_u32(f, "conn", where);
    if (connections_.count(id)) return;  // the index section repeats the chunks' connection records
    const Fields d = parse_fields(body, n, where);
    const auto md5 = d.find("md5sum");
    add_connection(id, field(f, "topic", where), field(d, "type", where), md5 == d.end() ? "*" : md5->second, false,
                   where);
  }

  /// A connection (ROS 1) or channel (MCAP) of a topic: `md5` the definition's sum (ROS 1; "*"
  /// unknown), `cdr` its messages in ROS 2's CDR. A ROS 2 type name (pkg/msg/Type) is known as
  /// ROS 1's (pkg/Type), whose messages hold the same fields.
  void add_connection(std::uint32_t id, const std::string& topic, std::string type, const std::string& md5, bool cdr,
                      const std::string& where) {
    if (const auto msg = type.find("/msg/"); cdr && msg != std::string::npos) type.erase(msg, 4);
    Connection c;
    c.topic = topic;
    c.type = type;
    c.cdr = cdr;
    const KnownType* k = known_type(c.type);
    if (k && md5 != k->md5 && md5 != "*")
      throw InputError(where + ": topic " + c.topic + ": a " + c.type + " of another definition (MD5 " + md5 +
                       ", the standard message's " + k->md5 + ")");
    // A tf topic is read for a frame (--frame), and then only tf topics are.
    c.tf = k && k->role == Role::tf;
    c.tf_static = c.tf && topic.size() >= 9 && topic.compare(topic.size() - 9, 9, "tf_static") == 0;
    const bool poses = k && (k->role == Role::pose || c.tf);
    c.pose = poses && (pose_topic_.empty() ? c.tf == !frame_.empty() : c.topic == pose_topic_);
    if (!frame_.empty() && c.pose && !c.tf)
      throw InputError(path_ + ": --frame " + frame_ + ": --topic " + c.topic + " is a " + c.type +
                       ", not a tf topic (tf2_msgs/TFMessage): --frame picks a tf topic's transforms");
    c.jaw = !jaw_topic_.empty() && c.topic == jaw_topic_;
    if (c.jaw && !jaw_joint_.empty() && c.type != "sensor_msgs/JointState")
      throw InputError(path_ + ": --jaw-joint " + jaw_joint_ + ": --jaw-topic " + jaw_topic_ + " is a " + c.type +
                       ", not a sensor_msgs/JointState");
    if (c.jaw && !(k && k->role == Role::jaw))
      throw InputError(path_ + ": --jaw-topic " + jaw_topic_ + ": a " + c.type + " topic (a jaw opening is read from " +
                       "sensor_msgs/JointState, std_msgs/Float64 or std_msgs/Float32)");
    c.buttons = !button_topic_.empty() && c.topic == button_topic_;
    if (c.buttons && !(k && k->role == Role::buttons))
      throw InputError(path_ + ": --button-topic " + button_topic_ + ": a " + c.type + " topic (buttons are read from " +
                       "sensor_msgs/Joy)");
    if (!pose_topic_.empty() && c.topic == pose_topic_ && !c.pose)
      throw InputError(path_ + ": --topic " + pose_topic_ + ": a " + c.type + " topic (a pose is read from " +
                       "geometry_msgs/PoseStamped, TransformStamped, Pose or Transform, or a tf topic's transforms)");
    auto t = std::find_if(contents_.topics.begin(), contents_.topics.end(),
                          [&](const BagTopic& b) { return b.name == c.topic; });
    if (t == contents_.topics.end()) t = contents_.topics.insert(t, {c.topic, c.type, 0});
    if (t->type != c.type)
      throw InputError(where + ": topic " + c.topic + " holds both " + t->type + " and " + c.type + " messages");
    c.topic_index = static_cast<std::size_t>(t - contents_.topics.begin());
    connections_.emplace(id, std::move(c));
  }

  /// A ROS 1 message data record.
  void message(const Fields& f, const unsigned char* body, std::size_t n, const std::string& where) {
    const std::string& time = field(f, "time", where);
    if (time.size() != 8) throw InputError(where + ": a message's time of " + std::to_string(time.size()) + " bytes");
    on_message(field_u32(f, "conn", where), ros_time(reinterpret_cast<const unsigned char*>(time.data())), body, n, where);
  }

  /// A message of connection (channel) `id`, recorded at record_t (s).
  void on_message(std::uint32_t id, double record_t, const unsigned char* body, std::size_t n, const std::string& where) {
    const auto it = connections_.find(id);
    if (it == connections_.end())
      throw InputError(where + ": a message of connection " + std::to_string(id) + " before its connection record");
    const Connection& c = it->second;
    const std::size_t index = ++contents_.topics[c.topic_index].messages;
    // A topic not read: counted only (with --frame every tf topic is read, for the links above it).
    if (!c.pose && !c.jaw && !c.buttons && !(c.tf && !frame_.empty())) return;
    const std::string msg = path_ + ": " + c.topic + " message " + std::to_string(index);
    if (c.tf && !frame_.empty()) {  // every tf topic's links: the frame's and those above it
      decode_tf(body, n, msg, c.cdr, [&](const std::string& parent_id, const std::string& child_id, BagPose p) {
        const std::string parent = frame_id(parent_id), child = frame_id(child_id);
        count_link(parent, child);
        p.t.record = record_t;
        if (child == frame_) {
          if (!c.pose) return;  // another tf topic than the one --topic names
          if (frame_parent_.empty()) frame_parent_ = parent;
          else if (parent != frame_parent_)
            throw InputError(msg + ": frame " + frame_ + "'s parent is " + parent + " here, " + frame_parent_ +
                             " before (two trees give it)");
          poses_[c.topic].push_back(p);
          return;
        }
        TfLink& l = links_[child];
        if (l.parent.empty()) l.parent = parent;
        else if (parent != l.parent && l.other_parent.empty()) l.other_parent = parent;
        l.dynamic = l.dynamic || !c.tf_static;
        l.transforms.push_back(p);
      });
    } else if (c.tf) {
      decode_tf(body, n, msg, c.cdr, [&](const std::string& parent, const std::string& child, BagPose) {
        count_link(frame_id(parent), frame_id(child));
      });
    } else if (c.pose) {
      BagPose p = decode_pose(c.type, body, n, msg, c.cdr);
      p.t.record = record_t;
      poses_[c.topic].push_back(p);
    }
    if (c.jaw) {
      BagJaw j = decode_jaw(c.type, jaw_joint_, body, n, msg, c.cdr);
      j.t.record = record_t;
      contents_.jaw.push_back(j);
    }
    if (c.buttons) {
      BagButtons b = decode_buttons(body, n, msg, c.cdr);
      b.t.record = record_t;
      contents_.buttons.push_back(b);
    }
  }

  BagContents finish() {
    // Every topic, or (candidates) those whose poses were read.
    const auto listed = [&](bool candidates) {
      std::string s;
      for (const BagTopic& t : contents_.topics)
        if (!candidates || poses_.count(t.name))
          s += (s.empty() ? "" : ", ") + t.name + " (" + t.type + ", " + std::to_string(t.messages) + ")";
      return s.empty() ? std::string("none") : s;
    };
    const std::string cut = contents_.cut_bytes == 0 ? std::string()
                            : " (its last " + std::to_string(contents_.cut_bytes) +
                                  " bytes, a record cut short, are left out: a recording stopped while writing it?)";
    const auto has = [&](const std::string& name) { return !topic_type(name).empty(); };
    if (!pose_topic_.empty() && !has(pose_topic_))
      throw InputError(path_ + ": --topic " + pose_topic_ + ": the bag has no such topic; its topics: " + listed(false) + cut);
    if (!jaw_topic_.empty() && !has(jaw_topic_))
      throw InputError(path_ + ": --jaw-topic " + jaw_topic_ + ": the bag has no such topic; its topics: " + listed(false) + cut);
    const auto links = [&] {
      std::string s;
      for (const auto& [link, count] : frames_) s += (s.empty() ? "" : ", ") + link + " (" + std::to_string(count) + ")";
      return s.empty() ? std::string("none") : s;
    };
    const KnownType* named = pose_topic_.empty() ? nullptr : known_type(topic_type(pose_topic_));
    if (named && named->role == Role::tf && frame_.empty())
      throw InputError(path_ + ": --topic " + pose_topic_ + ": a tf topic: name the device's frame with --frame; its "
                       "transforms: " + links());
    if (!frame_.empty() && poses_.empty())
      throw InputError(path_ + ": --frame " + frame_ + ": no transform to it in " +
                       (pose_topic_.empty() ? std::string("the bag's tf topics") : pose_topic_) + "; their transforms: " +
                       links() + cut);
    if (poses_.empty())
      throw InputError(path_ + ": no pose topic (geometry_msgs/PoseStamped, TransformStamped, Pose or Transform) with "
                       "messages; its topics: " + listed(false) + cut +
                       (frames_.empty() && !has_tf() ? "" : "; a tf topic's transforms are read with --frame"));
    if (poses_.size() > 1)
      throw InputError(path_ + ": several pose topics: " + listed(true) + "; name the device's with --topic");
    contents_.pose_topic = poses_.begin()->first;
    contents_.poses = std::move(poses_.begin()->second);
    if (!frame_.empty()) compose_chain(cut);
    for (const BagTopic& t : contents_.topics) {
      if (t.name == contents_.pose_topic) contents_.pose_type = t.type;
      if (t.name == jaw_topic_) contents_.jaw_type = t.type;
    }
    if (!jaw_topic_.empty() && contents_.jaw.empty())
      throw InputError(path_ + ": --jaw-topic " + jaw_topic_ + ": the topic has no messages");
    if (!button_topic_.empty() && !has(button_topic_))
      throw InputError(path_ + ": --button-topic " + button_topic_ + ": the bag has no such topic; its topics: " +
                       listed(false) + cut);
    if (!button_topic_.empty() && contents_.buttons.empty())
      throw InputError(path_ + ": --button-topic " + button_topic_ + ": the topic has no messages");
    return std::move(contents_);
  }

  /// The frame's poses in the frame above it that the request names (--root-frame), or in the top
  /// of its tree: each composed with the links between, looked up at the pose's time (a held link's
  /// last transform; an interpolated one's two around it); a pose outside a link's times is left out.
  void compose_chain(const std::string& cut) {
    std::vector<std::string> up{frame_, frame_parent_};  // the frame, then the frames above it
    std::vector<TfLink*> above;                          // the link to each frame above the parent
    while (up.back() != root_frame_) {
      const auto l = links_.find(up.back());
      if (l == links_.end()) break;  // the tree's top
      TfLink& link = l->second;
      if (!link.other_parent.empty())
        throw InputError(path_ + ": --frame " + frame_ + ": frame " + l->first + " above it has two parents, " +
                         link.parent + " and " + link.other_parent + " (two trees give it)");
      if (std::find(up.begin(), up.end(), link.parent) != up.end())
        throw InputError(path_ + ": --frame " + frame_ + ": the tf links above it close a loop at " + link.parent);
      above.push_back(&link);
      up.push_back(link.parent);
    }
    const auto joined = [&](std::size_t from) {
      std::string s;
      for (std::size_t i = from; i < up.size(); ++i) s += (s.empty() ? "" : ", ") + up[i];
      return s;
    };
    if (!root_frame_.empty() && up.back() != root_frame_)
      throw InputError(path_ + ": --root-frame " + root_frame_ + ": not above " + frame_ + " in the bag's tf tree; " +
                       "the frames above it: " + joined(1) + cut);
    contents_.frame_chain.assign(up.rbegin(), up.rend());
    contents_.links.push_back({frame_parent_, frame_, contents_.poses.size(), false});
    // Each link above, held or sorted by time for the lookups.
    std::vector<bool> held(above.size());
    for (std::size_t k = 0; k < above.size(); ++k) {
      TfLink& l = *above[k];
      std::stable_sort(l.transforms.begin(), l.transforms.end(),
                       [](const BagPose& a, const BagPose& b) { return lookup_time(a.t) < lookup_time(b.t); });
      held[k] = !l.dynamic || l.transforms.size() == 1;
      contents_.links.insert(contents_.links.begin(), {l.parent, up[k + 1], l.transforms.size(), held[k]});
    }
    const auto link_name = [&](std::size_t k) { return above[k]->parent + " -> " + up[k + 1]; };
    std::vector<BagPose> kept;
    kept.reserve(contents_.poses.size());
    std::optional<std::size_t> outside;  // the first link a pose fell outside of
    for (const BagPose& p : contents_.poses) {
      const double t = lookup_time(p.t);
      BagPose x = p;
      bool inside = true;
      for (std::size_t k = 0; k < above.size() && inside; ++k) {
        const std::vector<BagPose>& tr = above[k]->transforms;
        if (held[k]) {
          x = compose(tr.back(), x);
          continue;
        }
        const auto next = std::upper_bound(tr.begin(), tr.end(), t,
                                           [](double v, const BagPose& b) { return v < lookup_time(b.t); });
        if (next == tr.begin() || (next == tr.end() && t > lookup_time(tr.back().t))) {
          inside = false;
          if (!outside) outside = k;
          break;
        }
        const BagPose& a = *(next - 1);
        BagPose at = a;
        if (next != tr.end()) {
          const double t0 = lookup_time(a.t), t1 = lookup_time(next->t);
          const double s = t1 > t0 ? (t - t0) / (t1 - t0) : 0.0;
          at.position = a.position + s * (next->position - a.position);
          at.orientation = slerp(a.orientation, next->orientation, s);
        }
        x = compose(at, x);
      }
      if (inside) kept.push_back(x);
    }
    contents_.outside_links = contents_.poses.size() - kept.size();
    if (kept.empty()) {
      const auto span = [](const std::vector<BagPose>& v) {
        return fixed_text(lookup_time(v.front().t), 4) + " .. " + fixed_text(lookup_time(v.back().t), 4) + " s";
      };
      throw InputError(path_ + ": --frame " + frame_ + ": none of its " + std::to_string(contents_.poses.size()) +
                       " transforms (" + span(contents_.poses) + ") is within the times of " + link_name(*outside) +
                       "'s (" + span(above[*outside]->transforms) + ") to compose them with" +
                       (root_frame_.empty() ? std::string(" (--root-frame " + frame_parent_ + " keeps them in " +
                                                          frame_parent_ + ")")
                                            : std::string()));
    }
    contents_.poses = std::move(kept);
  }

  /// Counts a transform of the link parent -> child (frames_, listed where a request names none).
  void count_link(const std::string& parent, const std::string& child) {
    const std::string link = parent + " -> " + child;
    auto seen = std::find_if(frames_.begin(), frames_.end(), [&](const auto& l) { return l.first == link; });
    if (seen == frames_.end()) frames_.emplace_back(link, 1);
    else ++seen->second;
  }

  std::string topic_type(const std::string& name) const {
    for (const BagTopic& t : contents_.topics)
      if (t.name == name) return t.type;
    return "";
  }
  bool has_tf() const {
    return std::any_of(contents_.topics.begin(), contents_.topics.end(), [](const BagTopic& t) {
      const KnownType* k = known_type(t.type);
      return k && k->role == Role::tf;
    });
  }

  const std::string path_, pose_topic_, jaw_topic_, frame_, jaw_joint_, button_topic_, root_frame_;
  std::vector<std::pair<std::string, std::size_t>> frames_;  // a tf topic's "parent -> child" links, counted
  std::string frame_parent_;
  std::map<std::string, TfLink> links_;  // with --frame: every other link of the tf topics, by child frame
  std::map<std::uint16_t, std::string> schemas_;  // MCAP: a schema's message type
  std::map<std::uint32_t, Connection> connections_;
  std::map<std::string, std::vector<BagPose>> poses_;  // by topic: the candidates when none is named
  std::vector<unsigned char> chunk_;
  BagContents contents_;
};

}  // namespace

BagContents read_rosbag(const std::string& path, const BagRequest& request) { return BagReader(path, request).read(); }

bool rosbag_reads(const std::string& codec) {
#if EBH_HAVE_BZIP2
  if (codec == "bz2") return true;
#endif
#if EBH_HAVE_LZ4
  if (codec == "lz4") return true;
#endif
#if EBH_HAVE_ZSTD
  if (codec == "zstd") return true;
#endif
  return codec == "none";
}

}  // namespace ebh
