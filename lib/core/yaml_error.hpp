#pragma once
// The one message for YAML text that yaml-cpp refuses and the one form of a message about a value
// (FILE:LINE: key 'KEY': WHAT), the one check of a map's keys and of tags, and the one reading of
// a `--set` value, for every reader of YAML input (scene files, sweep and synthesis plans, gate
// baselines, --set values). Header-only; its includers link yaml-cpp
// (lib/CMakeLists.txt: scene, io, gate, sweep).
//
// yaml-cpp parses nested lists and maps recursively and stops at a fixed depth (500 in 0.7) with
// DeepRecursion, a ParserException whose own message is "bad file": a file of 100000 `[` is such a
// stop, not a stack overflow, and is said as what it is.
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/exceptions.h>
#include <yaml-cpp/node/convert.h>
#include <yaml-cpp/node/impl.h>
#include <yaml-cpp/node/node.h>
#include <yaml-cpp/node/parse.h>

#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"

namespace ebh {

/// What is wrong with YAML text that yaml-cpp refused: "nested too deeply (...)" at its depth
/// limit, else "YAML syntax error: MESSAGE".
inline std::string yaml_parse_problem(const YAML::Exception& e) {
  if (const auto* deep = dynamic_cast<const YAML::DeepRecursion*>(&e))
    return "nested too deeply (over " + std::to_string(deep->depth()) +
           " levels of lists and maps, yaml-cpp's limit; ebh's files nest a few)";
  return "YAML syntax error: " + e.msg;
}

/// "WHERE:LINE: " and yaml_parse_problem(e) ("WHERE: " when yaml-cpp gives no position).
inline std::string yaml_parse_error(const std::string& where, const YAML::Exception& e) {
  std::string out = where;
  if (!e.mark.is_null()) {
    out += ':';
    out += std::to_string(e.mark.line + 1);
  }
  out += ": ";
  out += yaml_parse_problem(e);
  return out;
}

/// "FILE:LINE: key 'KEY': WHAT", the message of a value a reader of a YAML file refuses: LINE the
/// node's (yaml-cpp's Mark), left out where it has none (a node the file lacks: its reader passes
/// the map that lacks the key instead), "key 'KEY': " left out for the file's top (KEY "").
inline std::string yaml_key_error(const std::string& file, const YAML::Node& n, const std::string& key,
                                  const std::string& what) {
  std::string out = file;
  if (n.IsDefined() && n.Mark().line >= 0) out += ":" + std::to_string(n.Mark().line + 1);
  if (!key.empty()) out += ": key '" + key + "'";
  return out + ": " + what;
}

/// The one document of YAML text read with YAML::LoadAll (a null node when there is none). A
/// second one (after '---'), which a reader of the first would leave unread without a word, is an
/// InputError "WHERE:LINE: a second YAML document (after '---'): WHAT holds one".
inline YAML::Node only_yaml_document(const std::vector<YAML::Node>& documents, const std::string& where,
                                     const std::string& what) {
  for (std::size_t i = 1; i < documents.size(); ++i)
    if (documents[i].IsDefined() && !documents[i].IsNull())
      throw InputError(where + ":" + std::to_string(documents[i].Mark().line + 1) +
                       ": a second YAML document (after '---'): " + what + " holds one");
  return documents.empty() ? YAML::Node() : documents.front();
}

/// How a node appears in a message: its text (60 characters at most, control characters as '?'),
/// or what kind of node it is.
inline std::string yaml_shown(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "nothing";
  if (n.IsMap()) return "a map";
  if (n.IsSequence()) return "a list";
  const std::string& s = n.Scalar();
  std::string out;
  for (const char c : s.substr(0, 60)) out += static_cast<unsigned char>(c) < 0x20 ? '?' : c;
  if (s.size() > 60) out += "...";
  return "'" + out + "'";
}

/// The entries of map `node` at dotted key `key` ("" for the top), in file order, checked as every
/// reader of ebh's YAML checks them: a map, its keys non-empty text, each among `allowed` (any key
/// when it is empty), none given twice (yaml-cpp keeps both, and a reader would take one without a
/// word), no merge key. fail(node, full_key, what) throws; it names the file (with the node's line,
/// or the --set that gave the key) as its reader does.
template <class Allowed, class Fail>
std::vector<std::pair<std::string, YAML::Node>> yaml_map_entries(const YAML::Node& node, const std::string& key,
                                                                 const Allowed& allowed, Fail&& fail) {
  if (!node.IsMap()) fail(node, key, "expected a map, got " + yaml_shown(node));
  std::vector<std::pair<std::string, YAML::Node>> out;
  for (auto it = node.begin(); it != node.end(); ++it) {
    if (!it->first.IsScalar() || it->first.Scalar().empty())
      fail(it->first, key, "expected text keys, got " + yaml_shown(it->first));
    const std::string name = it->first.Scalar();
    const std::string full = key.empty() ? name : key + "." + name;
    if (name == "<<") fail(it->first, full, "YAML merge keys ('<<: *anchor') are not read: write the section's keys out");
    bool known = std::empty(allowed);
    std::string list;
    for (const auto& a : allowed) {
      known = known || name == a;
      list += (list.empty() ? "" : ", ") + std::string(a);
    }
    if (!known) fail(it->first, full, "unknown key (known: " + list + ")");
    for (const auto& [k, v] : out)
      if (k == name) fail(it->first, full, "given twice");
    out.emplace_back(name, it->second);
  }
  return out;
}

/// Whether a node carries no YAML tag: yaml-cpp gives "?" to a plain scalar and an untagged list or
/// map, "!" to a quoted scalar (and to the non-specific tag `!`), "" to nothing.
inline bool yaml_untagged(const YAML::Node& n) {
  const std::string& tag = n.Tag();
  return tag.empty() || tag == "?" || tag == "!";
}

/// Refuses a YAML tag (`!foo 3`, `!!str 3`) anywhere in `node` (at dotted key `key`, "" for the
/// top), on a value or a key: ebh reads every value by its key, never by a tag, so a tag would be
/// dropped without a word (`k_con: !mm 800` read as 800 N/m). fail(node, full_key, what) throws, as
/// yaml_map_entries' does.
template <class Fail>
void yaml_refuse_tags(const YAML::Node& node, const std::string& key, Fail&& fail) {
  auto refuse = [&](const YAML::Node& n, const std::string& k) {
    if (yaml_untagged(n)) return;
    // The core schema's tags as written (yaml-cpp hands out "tag:yaml.org,2002:str" for `!!str`).
    const std::string core = "tag:yaml.org,2002:";
    const std::string& tag = n.Tag();
    const std::string shown = tag.compare(0, core.size(), core) == 0 ? "!!" + tag.substr(core.size()) : tag;
    fail(n, k, "YAML tag '" + shown + "': ebh reads no tags (each key says what its value is): remove it");
  };
  refuse(node, key);
  if (node.IsMap()) {
    for (auto it = node.begin(); it != node.end(); ++it) {
      const std::string name = it->first.IsScalar() ? it->first.Scalar() : "?";
      const std::string full = key.empty() ? name : key + "." + name;
      refuse(it->first, full);
      yaml_refuse_tags(it->second, full, fail);
    }
  } else if (node.IsSequence()) {
    std::size_t i = 0;
    for (auto it = node.begin(); it != node.end(); ++it, ++i) yaml_refuse_tags(*it, key + "[" + std::to_string(i) + "]", fail);
  }
}

/// yaml_refuse_tags over the whole of file `file`'s `root`: an InputError "FILE:LINE: key 'KEY':
/// YAML tag ..." (yaml_key_error) at the first tag.
inline void yaml_refuse_tags_in(const std::string& file, const YAML::Node& root) {
  yaml_refuse_tags(root, "", [&file](const YAML::Node& n, const std::string& key, const std::string& what) {
    throw InputError(yaml_key_error(file, n, key, what));
  });
}

/// The value of `--set KEY=VALUE` (a sweep plan's overrides are passed on as such) as YAML reads it:
/// a number, a word, a list ([1, 2]), a map ({k_vol: 500}) or a quoted text; but a plain (unquoted)
/// value keeps its whole text, which YAML would end at " #" (a comment: `--set 'name=a #b'` named
/// the scene "a") or, from a '#' on, read as nothing. Throws YAML::Exception where the text is no YAML.
inline YAML::Node yaml_override_value(const std::string& text) {
  const std::size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return YAML::Load(text);
  const std::string trimmed = text.substr(begin, text.find_last_not_of(" \t\r\n") + 1 - begin);
  if (trimmed.front() == '#') return YAML::Node(trimmed);
  YAML::Node n = YAML::Load(text);
  if (n.IsScalar() && n.Tag() == "?") return YAML::Node(trimmed);
  return n;
}

}  // namespace ebh
