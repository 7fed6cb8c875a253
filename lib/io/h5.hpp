#pragma once
// A small RAII layer over the HDF5 C API: files, groups, datasets of a few numeric types with a
// shape (N, ...), extendable datasets that grow along their first dimension (per-tick rows,
// mesh snapshots), and string/numeric attributes. HDF5's own error printing is silenced; every
// failure becomes an InputError whose one-line message names the file and the object:
//   "out.h5: /haptic/force: shape (100, 2), expected (N, 3)".
// Handles are shared: a Group or Dataset keeps its file open until the last copy goes away.
//
// Writing a file the tools produce goes through AtomicFile (io/atomic.hpp + File::create): it is
// written under a temporary name and renamed when complete.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "io/atomic.hpp"

namespace ebh::h5 {

/// Element types a dataset or attribute may hold (native byte order in memory).
enum class Type { f64, f32, i32, i64, u8, u32 };

template <class T> constexpr Type type_of() {
  if constexpr (std::is_same_v<T, double>) return Type::f64;
  else if constexpr (std::is_same_v<T, float>) return Type::f32;
  else if constexpr (std::is_same_v<T, std::int32_t>) return Type::i32;
  else if constexpr (std::is_same_v<T, std::int64_t>) return Type::i64;
  else if constexpr (std::is_same_v<T, std::uint8_t>) return Type::u8;
  else if constexpr (std::is_same_v<T, std::uint32_t>) return Type::u32;
  else static_assert(sizeof(T) == 0, "unsupported HDF5 element type");
}

/// What the objects of one open file share: the first write that failed when one of them was
/// closed (closing a dataset writes its cached chunks; a destructor cannot throw), which
/// File::close() reports instead of committing a file with a hole.
struct FileState {
  std::string write_failure;  ///< "cannot write the file: OS reason", or empty
  /// A file opened for reading: names it in the line a crash inside HDF5 gives while it is open
  /// (io/atomic.hpp CrashNamesInput).
  std::unique_ptr<CrashNamesInput> reading;
};

/// Owns one HDF5 identifier (file, group, dataset, dataspace, type, attribute or property list)
/// and closes it with the matching H5?close.
class Handle {
 public:
  Handle() = default;
  explicit Handle(std::int64_t id, std::shared_ptr<FileState> state = nullptr) : id_(id), state_(std::move(state)) {}
  ~Handle() { reset(); }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& o) noexcept : id_(o.id_), state_(std::move(o.state_)) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) { reset(); id_ = o.id_; state_ = std::move(o.state_); o.id_ = -1; }
    return *this;
  }
  std::int64_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  /// The state of the file this object belongs to (null for dataspaces, types, property lists).
  const std::shared_ptr<FileState>& state() const { return state_; }
  /// Closes the identifier; a failure is recorded in the file's state (File::close() reports it).
  void reset();
  /// Gives up ownership without closing; returns the identifier.
  std::int64_t release();

 private:
  std::int64_t id_ = -1;
  std::shared_ptr<FileState> state_;
};

/// How a dataset is stored. Chunking is implied by `compress` and by extendable datasets.
struct WriteOptions {
  bool compress = false;  ///< shuffle + deflate (level 4), when the filter is available
};

/// Numbers read from a dataset with their shape (row-major, first dimension = time or index).
template <class T>
struct Array {
  std::vector<T> data;
  std::vector<std::size_t> shape;
  std::size_t rows() const { return shape.empty() ? 1 : shape[0]; }
};

/// Something that carries attributes: a file's root, a group or a dataset.
class Object {
 public:
  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  /// "FILE: /path" — the prefix of every message about this object.
  std::string where() const;

  bool has_attr(const std::string& name) const;
  void set_attr(const std::string& name, const std::string& value);
  void set_attr(const std::string& name, const char* value) { set_attr(name, std::string(value)); }
  void set_attr(const std::string& name, const std::vector<double>& values);
  void set_attr(const std::string& name, const std::vector<std::int64_t>& values);
  template <class T>
    requires std::is_arithmetic_v<T>
  void set_attr(const std::string& name, T value) {
    if constexpr (std::is_floating_point_v<T>) set_attr_f64(name, static_cast<double>(value));
    else set_attr_i64(name, static_cast<std::int64_t>(value));
  }

  /// Attribute readers throw InputError naming the object and attribute when it is missing or
  /// of the wrong kind (a number asked as a string, a vector asked as a scalar).
  std::string attr_string(const std::string& name) const;
  double attr_double(const std::string& name) const;
  std::int64_t attr_int(const std::string& name) const;
  std::vector<double> attr_doubles(const std::string& name) const;

 protected:
  Object() = default;
  Object(std::shared_ptr<Handle> h, std::string file, std::string path)
      : h_(std::move(h)), file_(std::move(file)), path_(std::move(path)) {}
  std::int64_t id() const;

  std::shared_ptr<Handle> h_;
  std::string file_;
  std::string path_;

 private:
  void set_attr_f64(const std::string& name, double value);
  void set_attr_i64(const std::string& name, std::int64_t value);
};

class Dataset : public Object {
 public:
  Dataset() = default;
  std::vector<std::size_t> shape() const;
  /// Reads all of it. T's kind must match the stored kind (floating point vs integer); HDF5
  /// converts width (float32 -> double). `expected` gives each dimension, -1 for any.
  template <class T>
  Array<T> read(const std::vector<std::ptrdiff_t>& expected = {}) const {
    Array<T> a;
    read_raw(type_of<T>(), expected, a.shape, [&a](std::size_t n) { a.data.resize(n); return static_cast<void*>(a.data.data()); });
    return a;
  }
  /// Reads `count` rows of the first dimension from row `first`, every `stride`-th (a window of a
  /// long dataset, or an outline of it), the shape checked against `expected` (all of it) first.
  /// Requires first + (count - 1) * stride < rows.
  template <class T>
  Array<T> read_rows(const std::vector<std::ptrdiff_t>& expected, std::size_t first, std::size_t count,
                     std::size_t stride = 1) const {
    Array<T> a;
    a.shape = checked_shape(type_of<T>(), expected);
    std::size_t row = 1;
    for (std::size_t d = 1; d < a.shape.size(); ++d) row *= a.shape[d];
    a.data.resize(count * row);
    read_rows_into(type_of<T>(), first, count, stride, a.data.data());
    if (!a.shape.empty()) a.shape[0] = count;
    return a;
  }
  /// Reads a 1-D dataset of strings (variable or fixed length); InputError when it is not one.
  std::vector<std::string> read_strings() const;
  /// check_stored_here for a reader of its own (values of `value_size` bytes): done by every read above.
  void require_stored(std::size_t value_size) const;

 protected:
  friend class Group;
  Dataset(std::shared_ptr<Handle> h, std::string file, std::string path)
      : Object(std::move(h), std::move(file), std::move(path)) {}

 private:
  template <class F>
  void read_raw(Type t, const std::vector<std::ptrdiff_t>& expected, std::vector<std::size_t>& shape, F alloc) const {
    shape = checked_shape(t, expected);
    std::size_t n = 1;
    for (auto d : shape) n *= d;
    read_into(t, alloc(n));
  }
  std::vector<std::size_t> checked_shape(Type t, const std::vector<std::ptrdiff_t>& expected) const;
  void read_into(Type t, void* out) const;
  void read_rows_into(Type t, std::size_t first, std::size_t count, std::size_t stride, void* out) const;
};

/// A dataset that grows along its first dimension: shape (rows, row_shape...), chunked.
template <class T>
class Appender;

class AppenderBase : public Dataset {
 public:
  AppenderBase() = default;
  std::size_t rows() const { return rows_; }
  std::size_t row_size() const { return row_size_; }

 protected:
  friend class Group;
  AppenderBase(Dataset d, Type t, std::vector<std::size_t> row_shape);
  void append_raw(const void* data, std::size_t n_rows);

  Type type_ = Type::f64;
  std::vector<std::size_t> row_shape_;
  std::size_t row_size_ = 1;
  std::size_t rows_ = 0;
};

template <class T>
class Appender : public AppenderBase {
 public:
  Appender() = default;
  explicit Appender(AppenderBase b) : AppenderBase(std::move(b)) {}
  /// Appends data.size() / row_size() rows; data.size() must be a multiple of row_size().
  void append(std::span<const T> data) { append_raw(data.data(), checked_rows(data.size())); }
  void append_row(std::span<const T> row) { append(row); }

 private:
  std::size_t checked_rows(std::size_t n) const;
};

class Group : public Object {
 public:
  Group() = default;

  /// Whether a link of that name (a relative path like "a/b" allowed) exists.
  bool has(const std::string& name) const;
  Group group(const std::string& name) const;          ///< existing group, else InputError
  Group create_group(const std::string& name);         ///< creates intermediate groups
  Group require_group(const std::string& name);        ///< opens or creates
  Dataset dataset(const std::string& name) const;      ///< existing dataset, else InputError

  /// Writes a dataset of the given shape (product of shape == data.size()).
  template <class T>
  Dataset write(const std::string& name, std::span<const T> data, const std::vector<std::size_t>& shape,
                const WriteOptions& opt = {}) {
    return write_raw(name, type_of<T>(), data.data(), data.size(), shape, opt);
  }
  template <class T>
  Dataset write(const std::string& name, const std::vector<T>& data, const std::vector<std::size_t>& shape,
                const WriteOptions& opt = {}) {
    return write<T>(name, std::span<const T>(data), shape, opt);
  }
  /// Writes a 1-D dataset of variable-length UTF-8 strings (what h5py reads with .asstr()).
  Dataset write_strings(const std::string& name, const std::vector<std::string>& values);
  /// Shortcut: reads dataset `name` with the expected shape (-1 = any).
  template <class T>
  Array<T> read(const std::string& name, const std::vector<std::ptrdiff_t>& expected = {}) const {
    return dataset(name).read<T>(expected);
  }

  /// Creates an empty extendable dataset of shape (0, row_shape...) chunked by `chunk_rows` rows.
  template <class T>
  Appender<T> create_appendable(const std::string& name, const std::vector<std::size_t>& row_shape,
                                std::size_t chunk_rows = 1024, const WriteOptions& opt = {}) {
    return Appender<T>(create_appendable_raw(name, type_of<T>(), row_shape, chunk_rows, opt));
  }

 protected:
  Group(std::shared_ptr<Handle> h, std::string file, std::string path)
      : Object(std::move(h), std::move(file), std::move(path)) {}

 private:
  std::string child_path(const std::string& name) const;
  Dataset write_raw(const std::string& name, Type t, const void* data, std::size_t n,
                    const std::vector<std::size_t>& shape, const WriteOptions& opt);
  AppenderBase create_appendable_raw(const std::string& name, Type t, const std::vector<std::size_t>& row_shape,
                                     std::size_t chunk_rows, const WriteOptions& opt);
};

/// An open HDF5 file; also its root group "/".
class File : public Group {
 public:
  File() = default;
  /// Creates or truncates `path`; messages call it `name` when given (an AtomicFile's final name,
  /// not its temporary).
  static File create(const std::string& path, const std::string& name = "");
  /// Opens an existing file for reading; check_input_file() first (io/paths.hpp).
  static File open_read(const std::string& path);
  static File open_write(const std::string& path);  ///< existing file, read-write
  /// Writes out everything cached and closes the file and every object still open in it. Throws
  /// InputError "FILE: cannot write the file: OS reason" when a write fails (a full disk), after
  /// abandon().
  void close();
  /// Gives the file up without closing it: for a file that will be removed (uncommitted, or a
  /// write failed). HDF5 (1.10) cannot close a file whose writes failed: the close writes again,
  /// fails and leaves freed objects behind that a later close crashes on. So the identifier is
  /// left open (no exit handler closes it: see h5.cpp) and the descriptor goes at exit.
  void abandon();

 private:
  File(std::shared_ptr<Handle> h, std::string path) : Group(std::move(h), path, "/") {}
};

/// An HDF5 output file written atomically: created as .OUT.HOST.PID.ebh-partial beside OUT
/// (io/atomic.hpp), renamed to OUT by commit(); messages name OUT. Destroyed uncommitted (an
/// exception, an interrupt, a failed write) it removes the temporary file.
///   h5::AtomicFile out(path);
///   out.file().write<double>("t", t, {t.size()});
///   out.commit();
class AtomicFile {
 public:
  explicit AtomicFile(const std::string& final_path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  File& file() { return file_; }
  const std::string& final_path() const { return out_.final_path(); }
  /// Closes the file (every write checked), syncs and renames it; throws InputError (and removes
  /// the temporary, leaving a previous OUT as it was) when a write fails, the run was interrupted
  /// or the rename fails.
  void commit();
  /// The two halves of commit(), for an output read back before it takes the previous one's place
  /// (`ebh replay --render` renders its frames from it): close_and_sync() closes the file (every
  /// write checked) and syncs it under temp_path(), throwing as commit() does; publish() renames
  /// it into place whatever signal arrived since (the frames rendered from it are in place by then),
  /// throwing when the rename fails.
  void close_and_sync();
  void publish();
  const std::string& temp_path() const { return out_.temp_path(); }

 private:
  AtomicOutput out_;
  File file_;
};

/// Silences HDF5's automatic error printing (idempotent; done by every File factory).
void silence_errors();

/// Opens the existing file `path` read-only (check_input_file() first, io/paths.hpp) and returns
/// its HDF5 identifier, for File::open_read and the readers that use the HDF5 library directly.
/// Throws InputError "PATH: why": not an HDF5 file, cut short (with its sizes), a damaged header
/// (its size and HDF5's innermost reason), held open for writing by another program.
std::int64_t open_file_read(const std::string& path);

/// The message of a failed read of `dataset` (an HDF5 identifier), "cannot read WHAT: why": a
/// compression filter this library lacks (h5py's lzf) by name, compressed data that does not
/// decompress (a damaged file), else no reason. Reads HDF5's error stack: call it right after the
/// failed call. For readers that use the HDF5 library directly.
std::string read_failure(std::int64_t dataset, const std::string& what = "the dataset");

/// Whether every component of `name` (relative to the group `loc`, whose path is `parent`, or
/// absolute) exists as a link. A component that is an external or user-defined link is refused
/// (InputError naming `file` and the path): its target is another file, which may be anything (a
/// FIFO blocks the reader forever). For readers that use the HDF5 library directly too.
bool path_exists(std::int64_t loc, const std::string& name, const std::string& file, const std::string& parent = "/");

/// Refuses, before a read, a dataset (an HDF5 identifier) whose data its file does not hold: kept
/// in other files (raw external storage, a virtual dataset), or a declared shape of more than it
/// stores (read as `value_size` bytes a value: a dataset created with a shape and not its data,
/// which a reader would allocate in full). `where` names it. For readers that use the HDF5 library
/// directly too.
void check_stored_here(std::int64_t dataset, const std::string& where, std::size_t value_size);

[[noreturn]] void throw_bad_append(const std::string& where, std::size_t n, std::size_t row_size);

template <class T>
std::size_t Appender<T>::checked_rows(std::size_t n) const {
  if (row_size_ == 0 || n % row_size_ != 0) throw_bad_append(where(), n, row_size_);
  return n / row_size_;
}

}  // namespace ebh::h5
