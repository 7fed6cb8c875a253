#include "mesh/text_cursor.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <system_error>

#include "core/error.hpp"
#include "core/partial_output.hpp"

namespace ebh::detail {

std::ifstream open_input_file(const std::filesystem::path& file) {
  if (is_partial_output(file.string())) throw InputError(partial_input_message(file.string()));
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) throw InputError(file.string() + ": is a directory, expected a file");
  errno = 0;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string() + ": cannot open file" + (errno ? std::string(": ") + std::strerror(errno) : std::string()));
  return in;
}

std::string read_file_bytes(const std::filesystem::path& file) {
  std::ifstream in = open_input_file(file);
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(file.string() + ": cannot read file");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  in.seekg(0, std::ios::beg);
  if (size > 0 && !in.read(bytes.data(), size)) throw InputError(file.string() + ": cannot read file");
  return bytes;
}

std::string printable(std::string_view token) {
  constexpr std::size_t kMax = 40;
  std::string out;
  for (std::size_t i = 0; i < token.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f && c != '\'') {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  if (token.size() > kMax) out += "...";
  return out;
}

}  // namespace ebh::detail
