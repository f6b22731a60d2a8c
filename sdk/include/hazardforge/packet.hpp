// Immutable, shared, timestamped packets: the only thing that travels along a graph edge.
#pragma once

#include "hazardforge/abi.hpp"

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "hazardforge/error.hpp"

HF_SDK_BEGIN
namespace hf {

// A payload type is any struct with `static constexpr const char* kTypeName` and `static constexpr int
// kTypeVersion`. Types are compared by name and version (never typeid, which differs across libraries).
template <class T>
concept PayloadType = requires {
  { T::kTypeName } -> std::convertible_to<const char*>;
  { T::kTypeVersion } -> std::convertible_to<int>;
};

template <class T>
concept JsonSerializable = requires(nlohmann::json& j, const T& v) { to_json(j, v); };

class Packet {
 public:
  Packet() = default;

  template <PayloadType T>
  static Packet make(T value, double timestamp) {
    Packet p;
    p.data_ = std::make_shared<const T>(std::move(value));
    p.type_ = T::kTypeName;
    p.version_ = T::kTypeVersion;
    p.timestamp_ = timestamp;
    if constexpr (JsonSerializable<T>) {
      p.to_json_ = [](const void* v) {
        nlohmann::json j;
        to_json(j, *static_cast<const T*>(v));
        return j;
      };
    }
    return p;
  }

  bool empty() const { return data_ == nullptr; }
  // The same payload with another timestamp (the host stamps a source's packets with its frame's time).
  Packet restamped(double timestamp) const {
    Packet p = *this;
    p.timestamp_ = timestamp;
    return p;
  }
  double timestamp() const { return timestamp_; }
  const std::string& type_name() const { return type_; }
  int type_version() const { return version_; }

  template <PayloadType T>
  bool is() const {
    return data_ && type_ == T::kTypeName && version_ == T::kTypeVersion;
  }

  template <PayloadType T>
  const T& get() const {
    if (!is<T>()) {
      throw Error(std::string("packet holds '") + (data_ ? type_ + " v" + std::to_string(version_) : "nothing") +
                  "', not '" + T::kTypeName + " v" + std::to_string(T::kTypeVersion) + "'");
    }
    return *static_cast<const T*>(data_.get());
  }

  template <PayloadType T>
  std::shared_ptr<const T> share() const {
    (void)get<T>();
    return std::static_pointer_cast<const T>(data_);
  }

  bool serializable() const { return static_cast<bool>(to_json_); }
  nlohmann::json as_json() const { return to_json_ ? to_json_(data_.get()) : nlohmann::json(); }

 private:
  std::shared_ptr<const void> data_;
  std::string type_;
  int version_ = 0;
  double timestamp_ = 0.0;
  std::function<nlohmann::json(const void*)> to_json_;
};

}  // namespace hf
HF_SDK_END
