#include "scene/json_reader.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/errors.h"

namespace iqmpm {
namespace {

std::string type_name(const Json& value) {
  if (value.is_number()) return "a number";
  if (value.is_string()) return "a string";
  if (value.is_boolean()) return "a boolean";
  if (value.is_array()) return "an array";
  if (value.is_object()) return "an object";
  return "null";
}

std::string format_number(Real v) { return fmt::format("{:g}", v); }

std::string format_range(Real min, Real max, bool min_exclusive, bool max_exclusive = false) {
  const bool has_min = std::isfinite(min), has_max = std::isfinite(max);
  const char* below = max_exclusive ? "<" : "<=";
  if (has_min && has_max)
    return fmt::format("{} {} and {} {}", min_exclusive ? ">" : ">=", format_number(min), below, format_number(max));
  if (has_min) return fmt::format("{} {}", min_exclusive ? ">" : ">=", format_number(min));
  if (has_max) return fmt::format("{} {}", below, format_number(max));
  return "any finite number";
}

}  // namespace

JsonReader::JsonReader(const Json& object, std::string path, std::vector<KeyDoc>* docs)
    : object_(object), path_(std::move(path)), docs_(docs) {
  if (!docs_ && !object_.is_object())
    throw InputError(fmt::format("scene key '{}': expected an object, got {}", path_.empty() ? "(root)" : path_, type_name(object_)));
}

bool JsonReader::has(const std::string& key) const { return !docs_ && object_.contains(key); }

const Json* JsonReader::find(const std::string& key) {
  read_.insert(key);
  if (docs_ || !object_.contains(key)) return nullptr;
  return &object_.at(key);
}

void JsonReader::document(const std::string& key, const std::string& type, const std::string& fallback,
                          const std::string& accepted, const std::string& meaning) {
  if (docs_) docs_->push_back({key_path(key), type, fallback, accepted, meaning});
}

Real JsonReader::number(const std::string& key, std::optional<Real> fallback, Real min, Real max,
                        const std::string& meaning, bool min_exclusive, bool max_exclusive) {
  const std::string range = format_range(min, max, min_exclusive, max_exclusive);
  document(key, "number", fallback ? format_number(*fallback) : "required", range, meaning);
  const Json* value = find(key);
  if (!value) {
    if (fallback) return *fallback;
    if (docs_) return std::isfinite(min) ? min + 1 : 1;
    throw InputError(fmt::format("scene key '{}' is required: {} ({})", key_path(key), meaning, range));
  }
  if (!value->is_number())
    throw InputError(fmt::format("scene key '{}': expected a number ({}), got {}", key_path(key), range, type_name(*value)));
  const Real v = value->get<Real>();
  if (!std::isfinite(v) || v < min || v > max || (min_exclusive && v == min) || (max_exclusive && v == max))
    throw InputError(fmt::format("scene key '{}' = {}: out of range, accepted: {}", key_path(key), format_number(v), range));
  return v;
}

int JsonReader::integer(const std::string& key, std::optional<int> fallback, int min, int max, const std::string& meaning) {
  const std::string range = format_range(min, max, false);
  document(key, "integer", fallback ? std::to_string(*fallback) : "required", range, meaning);
  const Json* value = find(key);
  if (!value) {
    if (fallback) return *fallback;
    if (docs_) return min;
    throw InputError(fmt::format("scene key '{}' is required: {} (integer {})", key_path(key), meaning, range));
  }
  if (!value->is_number_integer())
    throw InputError(fmt::format("scene key '{}': expected an integer ({}), got {}", key_path(key), range, type_name(*value)));
  const long long v = value->get<long long>();
  if (v < min || v > max)
    throw InputError(fmt::format("scene key '{}' = {}: out of range, accepted: integer {}", key_path(key), v, range));
  return int(v);
}

bool JsonReader::boolean(const std::string& key, std::optional<bool> fallback, const std::string& meaning) {
  document(key, "boolean", fallback ? (*fallback ? "true" : "false") : "required", "true or false", meaning);
  const Json* value = find(key);
  if (!value) {
    if (fallback) return *fallback;
    if (docs_) return false;
    throw InputError(fmt::format("scene key '{}' is required: {} (true or false)", key_path(key), meaning));
  }
  if (!value->is_boolean())
    throw InputError(fmt::format("scene key '{}': expected true or false, got {}", key_path(key), type_name(*value)));
  return value->get<bool>();
}

std::string JsonReader::choice(const std::string& key, std::optional<std::string> fallback,
                               const std::vector<std::string>& accepted, const std::string& meaning) {
  const std::string list = fmt::format("one of {}", fmt::join(accepted, ", "));
  document(key, "string", fallback ? *fallback : "required", list, meaning);
  const Json* value = find(key);
  if (!value) {
    if (fallback) return *fallback;
    if (docs_) return accepted.front();
    throw InputError(fmt::format("scene key '{}' is required: {} ({})", key_path(key), meaning, list));
  }
  if (!value->is_string())
    throw InputError(fmt::format("scene key '{}': expected a string ({}), got {}", key_path(key), list, type_name(*value)));
  const std::string v = value->get<std::string>();
  for (const auto& a : accepted)
    if (a == v) return v;
  throw InputError(fmt::format("scene key '{}' = \"{}\": not accepted, expected {}", key_path(key), v, list));
}

std::string JsonReader::text(const std::string& key, std::optional<std::string> fallback, const std::string& meaning) {
  document(key, "string", fallback ? (fallback->empty() ? "\"\"" : *fallback) : "required", "any text", meaning);
  const Json* value = find(key);
  if (!value) {
    if (fallback) return *fallback;
    if (docs_) return "example";
    throw InputError(fmt::format("scene key '{}' is required: {}", key_path(key), meaning));
  }
  if (!value->is_string())
    throw InputError(fmt::format("scene key '{}': expected a string, got {}", key_path(key), type_name(*value)));
  return value->get<std::string>();
}

std::vector<Real> JsonReader::vector(const std::string& key, std::optional<std::vector<Real>> fallback, int length,
                                     const std::string& meaning) {
  const std::string shape = fmt::format("array of {} numbers", length);
  document(key, "array", fallback ? fmt::format("[{}]", fmt::join(*fallback, ", ")) : "required", shape, meaning);
  const Json* value = find(key);
  if (!value) {
    if (fallback) return *fallback;
    if (docs_) return std::vector<Real>(length, 0.5);
    throw InputError(fmt::format("scene key '{}' is required: {} ({})", key_path(key), meaning, shape));
  }
  if (!value->is_array() || int(value->size()) != length)
    throw InputError(fmt::format("scene key '{}': expected an {} (the scene's dim), got {}", key_path(key), shape,
                                 value->is_array() ? fmt::format("{} entries", value->size()) : type_name(*value)));
  std::vector<Real> out;
  for (std::size_t i = 0; i < value->size(); ++i) {
    const Json& entry = (*value)[i];
    if (!entry.is_number() || !std::isfinite(entry.get<Real>()))
      throw InputError(fmt::format("scene key '{}[{}]': expected a finite number, got {}", key_path(key), i, type_name(entry)));
    out.push_back(entry.get<Real>());
  }
  return out;
}

std::vector<Real> JsonReader::numbers(const std::string& key, std::optional<std::vector<Real>> fallback, int min_length,
                                      const std::string& meaning) {
  const std::string shape = fmt::format("array of at least {} numbers", min_length);
  document(key, "array", fallback ? fmt::format("[{}]", fmt::join(*fallback, ", ")) : "required", shape, meaning);
  const Json* value = find(key);
  if (!value) {
    if (fallback) return *fallback;
    if (docs_) return std::vector<Real>(min_length, 0.5);
    throw InputError(fmt::format("scene key '{}' is required: {} ({})", key_path(key), meaning, shape));
  }
  if (!value->is_array() || int(value->size()) < min_length)
    throw InputError(fmt::format("scene key '{}': expected an {}, got {}", key_path(key), shape, type_name(*value)));
  std::vector<Real> out;
  for (std::size_t i = 0; i < value->size(); ++i) {
    const Json& entry = (*value)[i];
    if (!entry.is_number())
      throw InputError(fmt::format("scene key '{}[{}]': expected a number, got {}", key_path(key), i, type_name(entry)));
    out.push_back(entry.get<Real>());
  }
  return out;
}

JsonReader JsonReader::object(const std::string& key, const std::string& meaning) {
  document(key, "object", "{}", "object", meaning);
  const Json* value = find(key);
  if (!value) return JsonReader(Json::object(), key_path(key), docs_);
  return JsonReader(*value, key_path(key), docs_);
}

std::vector<JsonReader> JsonReader::objects(const std::string& key, const std::string& meaning) {
  document(key, "array", "[]", "array of objects", meaning);
  const Json* value = find(key);
  std::vector<JsonReader> out;
  if (!value) return out;
  if (!value->is_array())
    throw InputError(fmt::format("scene key '{}': expected an array of objects, got {}", key_path(key), type_name(*value)));
  for (std::size_t i = 0; i < value->size(); ++i)
    out.emplace_back((*value)[i], fmt::format("{}[{}]", key_path(key), i), docs_);
  return out;
}

namespace {

// Levenshtein distance: how many single-character edits turn a into b.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

void JsonReader::finish() const {
  if (docs_) return;
  std::vector<std::string> unknown;
  for (const auto& item : object_.items())
    if (!read_.count(item.key())) unknown.push_back(item.key());
  if (unknown.empty()) return;
  std::set<std::string> accepted = read_;
  accepted.insert(also_accepted_.begin(), also_accepted_.end());
  // A key within two edits of an accepted one (and not much shorter) is most likely a typo.
  std::string suggestion;
  std::size_t best = 3;
  for (const auto& key : accepted) {
    const std::size_t distance = edit_distance(unknown.front(), key);
    if (distance < best && distance < std::max<std::size_t>(key.size(), 2)) best = distance, suggestion = key;
  }
  throw InputError(fmt::format("unknown scene key '{}'{}; accepted keys here: {}", key_path(unknown.front()),
                               suggestion.empty() ? "" : fmt::format(" (did you mean '{}'?)", suggestion),
                               fmt::join(accepted, ", ")));
}

void apply_override(Json& document, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(fmt::format("--set '{}': expected key=value, e.g. dx=0.002 or solver.method=pcg", assignment));
  const std::string path = assignment.substr(0, eq);
  const std::string raw = assignment.substr(eq + 1);
  Json value = Json::parse(raw, nullptr, false);
  if (value.is_discarded()) value = raw;
  Json* node = &document;
  std::size_t start = 0;
  while (true) {
    const auto dot = path.find('.', start);
    const std::string part = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (part.empty()) throw InputError(fmt::format("--set '{}': empty key in path", assignment));
    const bool last = dot == std::string::npos;
    if (node->is_array()) {
      std::size_t index = 0;
      try {
        index = std::stoul(part);
      } catch (...) {
        throw InputError(fmt::format("--set '{}': '{}' indexes an array, expected a number", assignment, part));
      }
      if (index >= node->size())
        throw InputError(fmt::format("--set '{}': index {} out of range (array has {} entries)", assignment, index, node->size()));
      node = &(*node)[index];
    } else if (node->is_object()) {
      if (last) {
        (*node)[part] = value;
        return;
      }
      if (!node->contains(part)) (*node)[part] = Json::object();
      node = &(*node)[part];
    } else {
      throw InputError(fmt::format("--set '{}': '{}' is not an object or array", assignment, part));
    }
    if (last) {
      *node = value;
      return;
    }
    start = dot + 1;
  }
}

}  // namespace iqmpm
