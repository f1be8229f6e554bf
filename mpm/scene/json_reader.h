// Reads a JSON scene with validation: every value is read through one call that names
// its key, type, default, accepted range and meaning. An unknown key, a wrong type or a
// value out of range raises InputError naming the key path and what is accepted. The
// same calls, run in documentation mode, produce the reference table of all keys
// (`iqmpm keys`), so defaults live in exactly one place.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <initializer_list>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/types.h"

namespace iqmpm {

using Json = nlohmann::json;

struct KeyDoc {
  std::string path, type, default_value, accepted, meaning;
};

class JsonReader {
 public:
  // Reads `object` found at `path` ("" for the root). docs != nullptr: documentation mode,
  // where every read records its key and returns its default (or a placeholder).
  JsonReader(const Json& object, std::string path, std::vector<KeyDoc>* docs = nullptr);

  Real number(const std::string& key, std::optional<Real> fallback, Real min, Real max,
              const std::string& meaning, bool min_exclusive = false, bool max_exclusive = false);
  int integer(const std::string& key, std::optional<int> fallback, int min, int max, const std::string& meaning);
  bool boolean(const std::string& key, std::optional<bool> fallback, const std::string& meaning);
  std::string choice(const std::string& key, std::optional<std::string> fallback,
                     const std::vector<std::string>& accepted, const std::string& meaning);
  // A choice read into an enum once, so that nothing downstream compares strings.
  template <class Enum>
  Enum option(const std::string& key, std::optional<Enum> fallback, const std::vector<std::pair<std::string, Enum>>& names,
              const std::string& meaning) {
    std::vector<std::string> accepted;
    std::optional<std::string> fallback_name;
    for (const auto& [name, value] : names) {
      accepted.push_back(name);
      if (fallback && value == *fallback) fallback_name = name;
    }
    const std::string chosen = choice(key, fallback_name, accepted, meaning);
    for (const auto& [name, value] : names)
      if (name == chosen) return value;
    return names.front().second;  // documentation mode without a default
  }
  std::string text(const std::string& key, std::optional<std::string> fallback, const std::string& meaning);
  // A fixed-length array of numbers (e.g. a point in `length` dimensions).
  std::vector<Real> vector(const std::string& key, std::optional<std::vector<Real>> fallback, int length,
                           const std::string& meaning);
  // An array of numbers of any length >= min_length.
  std::vector<Real> numbers(const std::string& key, std::optional<std::vector<Real>> fallback, int min_length,
                            const std::string& meaning);

  bool has(const std::string& key) const;
  // A nested object (absent: an empty one, so that its defaults apply).
  JsonReader object(const std::string& key, const std::string& meaning);
  // An array of objects; `documentation_example` is read in documentation mode.
  std::vector<JsonReader> objects(const std::string& key, const std::string& meaning);

  // Raises InputError for keys that no read asked for.
  void finish() const;
  // Keys this object accepts that this reading did not ask for (the other pair of an
  // either-or choice, e.g. mu and lambda beside youngs_modulus), named too when finish()
  // rejects an unknown key.
  void also_accepts(std::initializer_list<const char*> keys) { also_accepted_.insert(keys.begin(), keys.end()); }

  bool documenting() const { return docs_ != nullptr; }
  std::vector<KeyDoc>* docs() const { return docs_; }
  const std::string& path() const { return path_; }
  std::string key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

 private:
  const Json* find(const std::string& key);
  void document(const std::string& key, const std::string& type, const std::string& fallback,
                const std::string& accepted, const std::string& meaning);

  Json object_;
  std::string path_;
  std::vector<KeyDoc>* docs_;
  std::set<std::string> read_;
  std::set<std::string> also_accepted_;
};

// Applies `key.path=value` overrides to a JSON document (value parsed as JSON when it is
// valid JSON, else taken as a string). Array elements are addressed by index: shapes.0.max.
void apply_override(Json& document, const std::string& assignment);

}  // namespace iqmpm
