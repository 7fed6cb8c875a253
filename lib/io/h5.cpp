#include "io/h5.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <system_error>

#include "core/error.hpp"
#include "io/paths.hpp"

namespace ebh::h5 {

static_assert(sizeof(hid_t) == sizeof(std::int64_t), "HDF5 >= 1.10 uses 64-bit identifiers");

namespace {

hid_t mem_type(Type t) {
  switch (t) {
    case Type::f64: return H5T_NATIVE_DOUBLE;
    case Type::f32: return H5T_NATIVE_FLOAT;
    case Type::i32: return H5T_NATIVE_INT32;
    case Type::i64: return H5T_NATIVE_INT64;
    case Type::u8: return H5T_NATIVE_UINT8;
    case Type::u32: return H5T_NATIVE_UINT32;
  }
  return H5T_NATIVE_DOUBLE;
}

bool is_float(Type t) { return t == Type::f64 || t == Type::f32; }

std::string shape_str(const std::vector<std::size_t>& s) {
  std::ostringstream o;
  o << '(';
  for (std::size_t i = 0; i < s.size(); ++i) o << (i ? ", " : "") << s[i];
  if (s.size() == 1) o << ',';
  o << ')';
  return o.str();
}

std::string expected_str(const std::vector<std::ptrdiff_t>& s) {
  std::ostringstream o;
  o << '(';
  for (std::size_t i = 0; i < s.size(); ++i) {
    o << (i ? ", " : "");
    if (s[i] < 0) o << (i == 0 ? "N" : "*");
    else o << s[i];
  }
  if (s.size() == 1) o << ',';
  o << ')';
  return o.str();
}

[[noreturn]] void fail(const std::string& where, const std::string& what) { throw InputError(where + ": " + what); }

// The descriptions on HDF5's error stack after a failed call, from the API call down to the
// innermost, one per line; clears the stack. Must run before the next HDF5 call, which clears it.
herr_t collect_desc(unsigned, const H5E_error2_t* e, void* data) {
  if (e && e->desc) *static_cast<std::string*>(data) += std::string(e->desc) + "\n";
  return 0;
}
std::string error_descriptions() {
  std::string out;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_desc, &out);
  H5Eclear2(H5E_DEFAULT);
  return out;
}

// The operating system's reason for the HDF5 call that just failed, read from HDF5's error stack
// (its file drivers record "errno = N" in their messages: a full disk, a file too large); empty
// when the failure was not the operating system's. Must run before the next HDF5 call.
std::string os_suffix() {
  const std::string errors = error_descriptions();
  const std::size_t at = errors.find("errno = ");
  const int err = at == std::string::npos ? 0 : std::atoi(errors.c_str() + at + 8);
  return err > 0 ? ": " + os_reason(err) : std::string();
}

// A file cut short (HDF5 records "truncated file: eof = N, ..., stored_eof = M" when the file ends
// before the size its superblock declares): "it ends after N of its M bytes: ...", else "".
std::string truncation(const std::string& errors) {
  const std::size_t at = errors.find("truncated file: eof = ");
  if (at == std::string::npos) return "";
  const char* p = errors.c_str() + at;
  unsigned long long eof = 0, stored = 0;
  const char* s = std::strstr(p, "stored_eof = ");
  if (std::sscanf(p, "truncated file: eof = %llu", &eof) != 1 || !s || std::sscanf(s, "stored_eof = %llu", &stored) != 1)
    return "it ends before the size it declares";
  return "it ends after " + std::to_string(eof) + " of its " + std::to_string(stored) + " bytes";
}

// A failed HDF5 call: "WHERE: WHAT: OS reason" (the reason when the OS gave one).
[[noreturn]] void fail_call(const std::string& where, const std::string& what) { fail(where, what + os_suffix()); }

Handle check(hid_t id, const std::string& where, const std::string& what) {
  if (id < 0) fail_call(where, what);
  return Handle(id);
}

void check_status(herr_t st, const std::string& where, const std::string& what) {
  if (st < 0) fail_call(where, what);
}

// Closes an identifier of any kind; returns the close's status.
herr_t close_id(hid_t id) {
  switch (H5Iget_type(id)) {
    case H5I_FILE: return H5Fclose(id);
    case H5I_GROUP: return H5Gclose(id);
    case H5I_DATASET: return H5Dclose(id);
    case H5I_DATASPACE: return H5Sclose(id);
    case H5I_DATATYPE: return H5Tclose(id);
    case H5I_ATTR: return H5Aclose(id);
    case H5I_GENPROP_LST: return H5Pclose(id);
    default: return 0;
  }
}

Handle string_type() {
  hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, H5T_VARIABLE);
  H5Tset_cset(t, H5T_CSET_UTF8);
  return Handle(t);
}

bool filters_available() {
  static const bool ok = H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0 && H5Zfilter_avail(H5Z_FILTER_SHUFFLE) > 0;
  return ok;
}

}  // namespace

namespace {
// HDF5 closes the files still open at exit from an atexit handler; an abandoned file (File::abandon)
// crashes it. Every file ebh writes is closed explicitly (AtomicFile::commit), so the handler has
// nothing to do: it is turned off before the library starts (H5dont_atexit must come first).
[[maybe_unused]] const bool g_no_exit_handler = [] {
  H5dont_atexit();
  return true;
}();
}  // namespace

void silence_errors() {
  static const bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)done;
}

[[noreturn]] void throw_bad_append(const std::string& where, std::size_t n, std::size_t row_size) {
  fail(where, "append of " + std::to_string(n) + " values, not a multiple of the row size " + std::to_string(row_size));
}

void Handle::reset() {
  if (id_ < 0) return;
  if (close_id(id_) < 0 && state_ && state_->write_failure.empty())
    state_->write_failure = "cannot write the file" + os_suffix();
  id_ = -1;
}

std::int64_t Handle::release() {
  const std::int64_t id = id_;
  id_ = -1;
  return id;
}

// ---------------------------------------------------------------------------------------------
// Object: attributes

std::string Object::where() const { return file_ + ": " + path_; }

std::int64_t Object::id() const {
  if (!h_ || !h_->valid()) throw InputError(file_ + ": " + path_ + ": use of a closed HDF5 object");
  return h_->get();
}

bool Object::has_attr(const std::string& name) const { return H5Aexists(id(), name.c_str()) > 0; }

namespace {

// Replaces an existing attribute of that name, then creates it with the given type and space.
Handle new_attr(hid_t obj, const std::string& where, const std::string& name, hid_t type, hid_t space) {
  if (H5Aexists(obj, name.c_str()) > 0) H5Adelete(obj, name.c_str());
  return check(H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), where,
               "cannot create attribute '" + name + "'");
}

Handle open_attr(hid_t obj, const std::string& where, const std::string& name) {
  if (H5Aexists(obj, name.c_str()) <= 0) fail(where, "missing attribute '" + name + "'");
  return check(H5Aopen(obj, name.c_str(), H5P_DEFAULT), where, "cannot open attribute '" + name + "'");
}

// Number of elements of an attribute whose class must be `cls`.
std::size_t attr_numbers(hid_t a, const std::string& where, const std::string& name, H5T_class_t cls,
                         const char* kind) {
  Handle type(H5Aget_type(a));
  H5T_class_t c = H5Tget_class(type.get());
  if (c != cls && !(cls == H5T_FLOAT && c == H5T_INTEGER))
    fail(where, "attribute '" + name + "' is not " + kind);
  Handle space(H5Aget_space(a));
  hssize_t n = H5Sget_simple_extent_npoints(space.get());
  return n < 0 ? 0 : static_cast<std::size_t>(n);
}

}  // namespace

void Object::set_attr(const std::string& name, const std::string& value) {
  Handle type = string_type();
  Handle space(H5Screate(H5S_SCALAR));
  Handle a = new_attr(id(), where(), name, type.get(), space.get());
  const char* p = value.c_str();
  check_status(H5Awrite(a.get(), type.get(), &p), where(), "cannot write attribute '" + name + "'");
}

void Object::set_attr_f64(const std::string& name, double value) {
  Handle space(H5Screate(H5S_SCALAR));
  Handle a = new_attr(id(), where(), name, H5T_IEEE_F64LE, space.get());
  check_status(H5Awrite(a.get(), H5T_NATIVE_DOUBLE, &value), where(), "cannot write attribute '" + name + "'");
}

void Object::set_attr_i64(const std::string& name, std::int64_t value) {
  Handle space(H5Screate(H5S_SCALAR));
  Handle a = new_attr(id(), where(), name, H5T_STD_I64LE, space.get());
  check_status(H5Awrite(a.get(), H5T_NATIVE_INT64, &value), where(), "cannot write attribute '" + name + "'");
}

void Object::set_attr(const std::string& name, const std::vector<double>& values) {
  hsize_t n = values.size();
  Handle space(H5Screate_simple(1, &n, nullptr));
  Handle a = new_attr(id(), where(), name, H5T_IEEE_F64LE, space.get());
  check_status(H5Awrite(a.get(), H5T_NATIVE_DOUBLE, values.data()), where(), "cannot write attribute '" + name + "'");
}

void Object::set_attr(const std::string& name, const std::vector<std::int64_t>& values) {
  hsize_t n = values.size();
  Handle space(H5Screate_simple(1, &n, nullptr));
  Handle a = new_attr(id(), where(), name, H5T_STD_I64LE, space.get());
  check_status(H5Awrite(a.get(), H5T_NATIVE_INT64, values.data()), where(), "cannot write attribute '" + name + "'");
}

std::string Object::attr_string(const std::string& name) const {
  Handle a = open_attr(id(), where(), name);
  Handle type(H5Aget_type(a.get()));
  if (H5Tget_class(type.get()) != H5T_STRING) fail(where(), "attribute '" + name + "' is not a string");
  Handle space(H5Aget_space(a.get()));
  if (H5Sget_simple_extent_npoints(space.get()) != 1) fail(where(), "attribute '" + name + "' is not a single string");
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mt = string_type();
    char* p = nullptr;
    check_status(H5Aread(a.get(), mt.get(), &p), where(), "cannot read attribute '" + name + "'");
    std::string s = p ? p : "";
    H5free_memory(p);
    return s;
  }
  std::size_t size = H5Tget_size(type.get());
  std::vector<char> buf(size + 1, '\0');
  Handle mt(H5Tcopy(H5T_C_S1));
  H5Tset_size(mt.get(), size + 1);
  check_status(H5Aread(a.get(), mt.get(), buf.data()), where(), "cannot read attribute '" + name + "'");
  return std::string(buf.data(), strnlen(buf.data(), size));
}

double Object::attr_double(const std::string& name) const {
  Handle a = open_attr(id(), where(), name);
  if (attr_numbers(a.get(), where(), name, H5T_FLOAT, "a number") != 1)
    fail(where(), "attribute '" + name + "' is not a single number");
  double v = 0;
  check_status(H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v), where(), "cannot read attribute '" + name + "'");
  return v;
}

std::int64_t Object::attr_int(const std::string& name) const {
  Handle a = open_attr(id(), where(), name);
  if (attr_numbers(a.get(), where(), name, H5T_INTEGER, "an integer") != 1)
    fail(where(), "attribute '" + name + "' is not a single integer");
  std::int64_t v = 0;
  check_status(H5Aread(a.get(), H5T_NATIVE_INT64, &v), where(), "cannot read attribute '" + name + "'");
  return v;
}

std::vector<double> Object::attr_doubles(const std::string& name) const {
  Handle a = open_attr(id(), where(), name);
  std::vector<double> v(attr_numbers(a.get(), where(), name, H5T_FLOAT, "numeric"));
  if (!v.empty())
    check_status(H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()), where(), "cannot read attribute '" + name + "'");
  return v;
}

// ---------------------------------------------------------------------------------------------
// Dataset

namespace {

/// The dimensions of a dataset (an HDF5 identifier) `where` names.
std::vector<std::size_t> dataset_shape(std::int64_t dataset, const std::string& where) {
  Handle space(H5Dget_space(dataset));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) fail(where, "cannot read the dataset's shape");
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return std::vector<std::size_t>(dims.begin(), dims.end());
}

}  // namespace

// (h5.hpp)
bool path_exists(std::int64_t loc, const std::string& name, const std::string& file, const std::string& parent) {
  std::size_t pos = 0;
  if (!name.empty() && name[0] == '/') pos = 1;
  while (true) {
    std::size_t next = name.find('/', pos);
    std::string prefix = name.substr(0, next);
    if (!prefix.empty() && prefix != "/") {
      htri_t e = H5Lexists(loc, prefix.c_str(), H5P_DEFAULT);
      if (e <= 0) return false;
      H5L_info_t info;
      if (H5Lget_info(loc, prefix.c_str(), &info, H5P_DEFAULT) >= 0 && info.type != H5L_TYPE_HARD &&
          info.type != H5L_TYPE_SOFT)
        fail(file + ": " + (prefix[0] == '/' ? prefix : parent == "/" ? "/" + prefix : parent + "/" + prefix),
             std::string(info.type == H5L_TYPE_EXTERNAL ? "an external link to another file" : "a user-defined link") +
                 ": ebh reads only what is stored in the file given; save a copy with the data in it (h5py: "
                 "f2['x'] = f['x'][()])");
      if (next != std::string::npos) {  // an intermediate component must be a group to continue
        // H5Oopen + H5Iget_type rather than H5Oget_info_by_name, whose signature changed in 1.12.
        hid_t o = H5Oopen(loc, prefix.c_str(), H5P_DEFAULT);
        if (o < 0) return false;
        bool is_group = H5Iget_type(o) == H5I_GROUP;
        H5Oclose(o);
        if (!is_group) return false;
      }
    }
    if (next == std::string::npos) return true;
    pos = next + 1;
  }
}

// (h5.hpp)
void check_stored_here(std::int64_t dataset, const std::string& where, std::size_t value_size) {
  Handle dcpl(H5Dget_create_plist(dataset));
  if (dcpl.get() >= 0 && (H5Pget_layout(dcpl.get()) == H5D_VIRTUAL || H5Pget_external_count(dcpl.get()) > 0))
    fail(where, std::string(H5Pget_layout(dcpl.get()) == H5D_VIRTUAL ? "a virtual dataset" : "a dataset") +
                    " whose data is stored in other files: ebh reads only what is stored in the file given; save a "
                    "copy with the data in it (h5py: f2['x'] = f['x'][()])");
  // Deflate stores at most ~1032 values' bytes per byte; a dataset of up to kUnstoredBytes is read
  // whatever it stores.
  constexpr double kMaxExpansion = 1100, kUnstoredBytes = 64.0 * (1 << 20);
  const std::vector<std::size_t> dims = dataset_shape(dataset, where);
  double declared = static_cast<double>(value_size);
  for (const std::size_t d : dims) declared *= static_cast<double>(d);
  const double stored = static_cast<double>(H5Dget_storage_size(dataset));
  if (declared > kUnstoredBytes && declared > kMaxExpansion * stored) {
    char what[160];
    std::snprintf(what, sizeof what, " (%.3g GB of values) but the file stores %.3g MB of it", declared * 1e-9,
                  stored * 1e-6);
    fail(where, "shape " + shape_str(dims) + what +
                    ": a dataset created with a shape and not its data, or a damaged file; write the data into it");
  }
}

// (h5.hpp) A filter the dataset was written with that this HDF5 library lacks (h5py's lzf, a
// blosc plugin) is named with what to do; `what` names the rows read, where only some were.
std::string read_failure(std::int64_t dataset, const std::string& what) {
  const std::string errors = error_descriptions();
  Handle plist(H5Dget_create_plist(dataset));
  const int n = plist.get() >= 0 ? H5Pget_nfilters(plist.get()) : 0;
  for (int i = 0; i < n; ++i) {
    unsigned flags = 0, config = 0;
    std::size_t nvalues = 0;
    char name[64] = "";
    const H5Z_filter_t filter = H5Pget_filter2(plist.get(), static_cast<unsigned>(i), &flags, &nvalues, nullptr,
                                               sizeof name, name, &config);
    if (filter >= 0 && H5Zfilter_avail(filter) <= 0)
      return "cannot read " + what + ": it is compressed with the filter '" + std::string(name) + "' (id " +
             std::to_string(filter) + "), which this HDF5 library does not have: save it with gzip " +
             "(h5py: compression='gzip') or none";
  }
  const char* damaged = ": the file is damaged (a copy or transfer that went wrong, a failing disk); read it from its "
                        "source again";
  // (checked first: a checksum that fails is reported by HDF5 as its filter failing too)
  if (n > 0 && (errors.find("fletcher32") != std::string::npos || errors.find("checksum") != std::string::npos))
    return "cannot read " + what + ": its checksum (fletcher32) does not match the data" + damaged;
  if (n > 0 && (errors.find("filter returned failure") != std::string::npos ||
                errors.find("inflate() failed") != std::string::npos))
    return "cannot read " + what + ": compressed data in it does not decompress" + damaged;
  return "cannot read " + what;
}

std::vector<std::size_t> Dataset::shape() const { return dataset_shape(id(), where()); }

std::vector<std::size_t> Dataset::checked_shape(Type t, const std::vector<std::ptrdiff_t>& expected) const {
  Handle type(H5Dget_type(id()));
  H5T_class_t cls = H5Tget_class(type.get());
  bool ok = is_float(t) ? cls == H5T_FLOAT : cls == H5T_INTEGER;
  if (!ok) {
    const char* stored = cls == H5T_FLOAT     ? "floating point"
                         : cls == H5T_INTEGER ? "integer"
                         : cls == H5T_STRING  ? "string"
                         : cls == H5T_ENUM    ? "enumerated (as h5py stores a bool: store the numbers)"
                                              : "non-numeric";
    // Of any width: HDF5 converts (a float32 or a uint8 is read as the double or int64 it holds).
    fail(where(), std::string("type ") + stored + ", expected " + (is_float(t) ? "floating point" : "integer") +
                      " (of any width)");
  }
  // The values' size in the file, not in memory: a recording's buttons are stored as uint8 and
  // read as int64, and 8 million zeros compress past the check's bound at 8 bytes a value.
  check_stored_here(id(), where(), H5Tget_size(type.get()));
  std::vector<std::size_t> s = shape();
  if (!expected.empty()) {
    bool match = s.size() == expected.size();
    for (std::size_t i = 0; match && i < s.size(); ++i)
      if (expected[i] >= 0 && s[i] != static_cast<std::size_t>(expected[i])) match = false;
    if (!match) fail(where(), "shape " + shape_str(s) + ", expected " + expected_str(expected));
  }
  return s;
}

void Dataset::require_stored(std::size_t value_size) const { check_stored_here(id(), where(), value_size); }

std::vector<std::string> Dataset::read_strings() const {
  Handle type(H5Dget_type(id()));
  if (H5Tget_class(type.get()) != H5T_STRING) fail(where(), "not a dataset of strings");
  check_stored_here(id(), where(), H5Tget_size(type.get()));
  const std::vector<std::size_t> s = shape();
  if (s.size() != 1) fail(where(), "shape " + shape_str(s) + ", expected (N,) strings");
  std::vector<std::string> out(s[0]);
  if (out.empty()) return out;
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mt = string_type();
    std::vector<char*> p(out.size(), nullptr);
    if (H5Dread(id(), mt.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, p.data()) < 0) fail(where(), read_failure(id(), "the dataset"));
    for (std::size_t i = 0; i < out.size(); ++i) {
      out[i] = p[i] ? p[i] : "";
      H5free_memory(p[i]);
    }
    return out;
  }
  const std::size_t size = H5Tget_size(type.get());
  std::vector<char> buf(out.size() * size);
  Handle mt(H5Tcopy(H5T_C_S1));
  H5Tset_size(mt.get(), size);
  if (H5Dread(id(), mt.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) fail(where(), read_failure(id(), "the dataset"));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = std::string(&buf[i * size], strnlen(&buf[i * size], size));
  return out;
}

void Dataset::read_into(Type t, void* out) const {
  Handle space(H5Dget_space(id()));
  if (H5Sget_simple_extent_npoints(space.get()) == 0) return;
  if (H5Dread(id(), mem_type(t), H5S_ALL, H5S_ALL, H5P_DEFAULT, out) < 0) fail(where(), read_failure(id(), "the dataset"));
}

void Dataset::read_rows_into(Type t, std::size_t first, std::size_t count, std::size_t stride, void* out) const {
  if (count == 0) return;
  stride = std::max<std::size_t>(stride, 1);
  Handle fspace(H5Dget_space(id()));
  const int rank = H5Sget_simple_extent_ndims(fspace.get());
  if (rank < 1) fail(where(), "cannot read rows of a scalar dataset");
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(fspace.get(), dims.data(), nullptr);
  if (first + (count - 1) * stride >= dims[0])
    fail(where(), "row " + std::to_string(first + (count - 1) * stride) + " past its " + std::to_string(dims[0]) +
                      " rows");
  // Contiguous rows are one block (a selection of one block per row costs HDF5 memory per row, a
  // gigabyte for a few million rows of a file written in chunks of a few rows); strided rows are
  // a block each.
  std::vector<hsize_t> start(dims.size(), 0), step(dims.size(), 1), n(dims.size(), 1), block(dims);
  start[0] = first;
  if (stride > 1) {
    step[0] = stride;
    n[0] = count;
    block[0] = 1;
  } else {
    block[0] = count;
  }
  check_status(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), step.data(), n.data(), block.data()),
               where(), "cannot select rows");
  std::vector<hsize_t> mdims(dims);
  mdims[0] = count;
  Handle mspace(H5Screate_simple(rank, mdims.data(), nullptr));
  if (H5Dread(id(), mem_type(t), mspace.get(), fspace.get(), H5P_DEFAULT, out) < 0)
    fail(where(), read_failure(id(), "rows " + std::to_string(first) + ".." + std::to_string(first + (count - 1) * stride) +
                                         " of " + std::to_string(dims[0])));
}

// ---------------------------------------------------------------------------------------------
// Appender

AppenderBase::AppenderBase(Dataset d, Type t, std::vector<std::size_t> row_shape)
    : Dataset(std::move(d)), type_(t), row_shape_(std::move(row_shape)) {
  row_size_ = 1;
  for (auto r : row_shape_) row_size_ *= r;
}

void AppenderBase::append_raw(const void* data, std::size_t n_rows) {
  if (n_rows == 0) return;
  std::vector<hsize_t> dims{static_cast<hsize_t>(rows_ + n_rows)};
  for (auto r : row_shape_) dims.push_back(r);
  check_status(H5Dset_extent(id(), dims.data()), where(), "cannot extend the dataset");
  Handle fspace(H5Dget_space(id()));
  std::vector<hsize_t> start(dims.size(), 0), count(dims);
  start[0] = rows_;
  count[0] = n_rows;
  check_status(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), where(),
               "cannot select the appended rows");
  Handle mspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr));
  check_status(H5Dwrite(id(), mem_type(type_), mspace.get(), fspace.get(), H5P_DEFAULT, data), where(),
               "cannot write the appended rows");
  rows_ += n_rows;
}

// ---------------------------------------------------------------------------------------------
// Group

std::string Group::child_path(const std::string& name) const {
  if (!name.empty() && name[0] == '/') return name;
  return path_ == "/" ? "/" + name : path_ + "/" + name;
}

bool Group::has(const std::string& name) const { return path_exists(id(), name, file_, path_); }

Group Group::group(const std::string& name) const {
  std::string p = child_path(name);
  if (!has(name)) fail(file_ + ": " + p, "missing group");
  hid_t g = H5Gopen2(id(), name.c_str(), H5P_DEFAULT);
  if (g < 0) fail(file_ + ": " + p, "not a group");
  return Group(std::make_shared<Handle>(g, h_->state()), file_, p);
}

Group Group::create_group(const std::string& name) {
  std::string p = child_path(name);
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE));
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  hid_t g = H5Gcreate2(id(), name.c_str(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) fail(file_ + ": " + p, "cannot create group");
  return Group(std::make_shared<Handle>(g, h_->state()), file_, p);
}

Group Group::require_group(const std::string& name) { return has(name) ? group(name) : create_group(name); }

Dataset Group::dataset(const std::string& name) const {
  std::string p = child_path(name);
  if (!has(name)) fail(file_ + ": " + p, "missing dataset");
  hid_t d = H5Dopen2(id(), name.c_str(), H5P_DEFAULT);
  if (d < 0) fail(file_ + ": " + p, "not a dataset");
  return Dataset(std::make_shared<Handle>(d, h_->state()), file_, p);
}

Dataset Group::write_raw(const std::string& name, Type t, const void* data, std::size_t n,
                         const std::vector<std::size_t>& shape, const WriteOptions& opt) {
  std::string p = child_path(name);
  std::size_t prod = 1;
  for (auto s : shape) prod *= s;
  if (prod != n)
    fail(file_ + ": " + p, std::to_string(n) + " values do not fill the shape " + shape_str(shape));
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  Handle space(shape.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE));
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  if (opt.compress && filters_available() && !dims.empty() && n > 0) {
    std::vector<hsize_t> chunk(dims);
    std::size_t row = n / dims[0];
    // About 64 KiB chunks along the first dimension.
    chunk[0] = std::max<hsize_t>(1, std::min<hsize_t>(dims[0], 65536 / std::max<std::size_t>(1, row * 8)));
    H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
    H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), 4);
  }
  hid_t d = H5Dcreate2(id(), name.c_str(), mem_type(t), space.get(), lcpl.get(), dcpl.get(), H5P_DEFAULT);
  if (d < 0) fail(file_ + ": " + p, "cannot create dataset (does it exist already?)");
  Dataset ds(std::make_shared<Handle>(d, h_->state()), file_, p);
  if (n > 0)
    check_status(H5Dwrite(d, mem_type(t), H5S_ALL, H5S_ALL, H5P_DEFAULT, data), ds.where(), "cannot write the dataset");
  return ds;
}

Dataset Group::write_strings(const std::string& name, const std::vector<std::string>& values) {
  const std::string p = child_path(name);
  hsize_t n = values.size();
  Handle space(H5Screate_simple(1, &n, nullptr));
  Handle type = string_type();
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE));
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  hid_t d = H5Dcreate2(id(), name.c_str(), type.get(), space.get(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT);
  if (d < 0) fail(file_ + ": " + p, "cannot create dataset (does it exist already?)");
  Dataset ds(std::make_shared<Handle>(d, h_->state()), file_, p);
  std::vector<const char*> ptr(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) ptr[i] = values[i].c_str();
  if (n > 0)
    check_status(H5Dwrite(d, type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptr.data()), ds.where(), "cannot write the dataset");
  return ds;
}

AppenderBase Group::create_appendable_raw(const std::string& name, Type t, const std::vector<std::size_t>& row_shape,
                                          std::size_t chunk_rows, const WriteOptions& opt) {
  std::string p = child_path(name);
  std::vector<hsize_t> dims{0}, maxdims{H5S_UNLIMITED}, chunk{std::max<hsize_t>(1, chunk_rows)};
  for (auto r : row_shape) { dims.push_back(r); maxdims.push_back(r); chunk.push_back(std::max<std::size_t>(1, r)); }
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxdims.data()));
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE));
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
  if (opt.compress && filters_available()) {
    H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), 4);
  }
  hid_t d = H5Dcreate2(id(), name.c_str(), mem_type(t), space.get(), lcpl.get(), dcpl.get(), H5P_DEFAULT);
  if (d < 0) fail(file_ + ": " + p, "cannot create dataset (does it exist already?)");
  return AppenderBase(Dataset(std::make_shared<Handle>(d, h_->state()), file_, p), t, row_shape);
}

// ---------------------------------------------------------------------------------------------
// File

File File::create(const std::string& path, const std::string& name) {
  silence_errors();
  const std::string shown = name.empty() ? path : name;
  // Closing a written file closes every object opened in it, so close() really ends the writing
  // (AtomicFile renames right after).
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS));
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get());
  if (f < 0) fail_call(shown, "cannot create HDF5 file");
  return File(std::make_shared<Handle>(f, std::make_shared<FileState>()), shown);
}

std::int64_t open_file_read(const std::string& path) {
  silence_errors();
  check_input_file(path);
  if (H5Fis_hdf5(path.c_str()) <= 0) throw InputError(path + ": not an HDF5 file");
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    const std::string errors = error_descriptions();
    if (const std::string cut = truncation(errors); !cut.empty())
      throw InputError(path + ": cannot open HDF5 file: it is cut short (" + cut + "): a copy or download that did not "
                              "finish, or a writer stopped before it closed the file");
    // The signature is there (H5Fis_hdf5) but the superblock after it is not one: a file that only
    // starts like an HDF5 file, or whose first bytes were overwritten.
    if (errors.find("superblock") != std::string::npos) {
      const std::size_t last = errors.find_last_of('\n', errors.size() - 2);
      const std::string innermost = errors.substr(last == std::string::npos ? 0 : last + 1);
      std::error_code ec;
      const auto bytes = std::filesystem::file_size(path, ec);
      throw InputError(path + ": cannot open HDF5 file: it starts with HDF5's signature but its header (superblock) is "
                              "damaged (" + (ec ? std::string() : std::to_string(bytes) + " bytes; ") + "HDF5: " +
                       innermost.substr(0, innermost.find('\n')) + "): a damaged copy, or no HDF5 file");
    }
#if H5_VERSION_GE(1, 10, 7)
    // A program writing the file holds HDF5's lock on it (a logger still running): named as such.
    Handle fapl(H5Pcreate(H5P_FILE_ACCESS));
    H5Pset_file_locking(fapl.get(), false, true);
    if (const hid_t unlocked = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()); unlocked >= 0) {
      H5Fclose(unlocked);
      throw InputError(path + ": cannot open HDF5 file: another program has it open for writing (a logger still "
                              "running?); close it first, or read a copy");
    }
#endif
    throw InputError(path + ": cannot open HDF5 file");
  }
  return f;
}

File File::open_read(const std::string& path) {
  auto state = std::make_shared<FileState>();
  state->reading = std::make_unique<CrashNamesInput>(path);  // from the open on
  return File(std::make_shared<Handle>(open_file_read(path), std::move(state)), path);
}

File File::open_write(const std::string& path) {
  silence_errors();
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (f < 0) throw InputError(path + ": cannot open HDF5 file for writing");
  return File(std::make_shared<Handle>(f, std::make_shared<FileState>()), path);
}

void File::close() {
  if (!h_ || !h_->valid()) return;
  const hid_t f = h_->get();
  auto failed = [this](const std::string& what) {
    abandon();
    fail(file_, what);
  };
  // A dataset of it that failed to write its chunks when it was closed: the file has a hole.
  if (!h_->state()->write_failure.empty()) failed(h_->state()->write_failure);
  // Everything still cached (chunks of open datasets, metadata) goes to the file now, where a
  // full disk shows.
  if (H5Fflush(f, H5F_SCOPE_LOCAL) < 0) failed("cannot write the file" + os_suffix());
  // Nothing is left to write: close the objects still open in it (an appender's dataset; their
  // handles then see a closed identifier), then the file.
  const unsigned kinds = H5F_OBJ_DATASET | H5F_OBJ_GROUP | H5F_OBJ_DATATYPE | H5F_OBJ_ATTR | H5F_OBJ_LOCAL;
  const ssize_t n = H5Fget_obj_count(f, kinds);
  std::vector<hid_t> ids(static_cast<std::size_t>(std::max<ssize_t>(n, 0)));
  const ssize_t got = n > 0 ? H5Fget_obj_ids(f, kinds, ids.size(), ids.data()) : 0;
  for (ssize_t i = 0; i < got; ++i)
    if (close_id(ids[static_cast<std::size_t>(i)]) < 0) failed("cannot write the file" + os_suffix());
  if (H5Fclose(f) < 0) failed("cannot close the file" + os_suffix());
  h_->release();
}

void File::abandon() {
  if (h_) h_->release();
  H5Eclear2(H5E_DEFAULT);
}

// ---------------------------------------------------------------------------------------------
// AtomicFile

AtomicFile::AtomicFile(const std::string& final_path) : out_(final_path) {
  file_ = File::create(out_.temp_path(), out_.final_path());
}

AtomicFile::~AtomicFile() {
  // Uncommitted (an exception, an interrupt): nothing of it is kept, so nothing more is written.
  if (!out_.committed()) file_.abandon();
}

void AtomicFile::commit() {
  close_and_sync();
  publish();
}

void AtomicFile::close_and_sync() {
  file_.close();
  out_.stop_if_interrupted();
  out_.sync();
}

void AtomicFile::publish() { out_.rename_into_place(); }

}  // namespace ebh::h5
