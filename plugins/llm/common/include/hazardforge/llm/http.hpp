// JSON-over-HTTP POST for the LLM providers (libcurl), with connect/read timeouts and uniform error texts.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <hazardforge/error.hpp>
#include <hazardforge/types.hpp>

#include "hazardforge/llm/json.hpp"

namespace hf::llm {

struct HttpTimeouts {
  double connect_s = 5.0;  // TCP connect
  double read_s = 300.0;   // whole request after the call starts (local models answer slowly)
};

// What one call may take in: a reply larger than `max_body_bytes` is cut off while it streams in, so a
// hostile or broken server cannot exhaust memory.
struct HttpLimits {
  size_t max_body_bytes = 1000000;
};

// Values a provider knows to be secret: its API key, the user:password of its server URL and the Basic
// authorization that libcurl makes of them (base64). scrub() replaces each in a text or in every string of a
// JSON document by "***", so a server that echoes the request's Authorization header (in an error, in its
// reply) puts nothing secret into messages, call records or specs. Values shorter than 4 characters are not
// searched for on their own (they would match ordinary text); as part of user:password they are.
class Secrets {
 public:
  void add(const std::string& value);
  void add_url_credentials(const std::string& url);
  std::string scrub(std::string text) const;
  Json scrub(const Json& j) const;

 private:
  std::vector<std::string> values_;  // longest first, so a value containing another is replaced whole
};

struct HttpResponse {
  long status = 0;
  std::string body;
};

// POSTs `body` as application/json. `who` prefixes every message (e.g. "ollama"). Transport failures throw
// hf::Error "<who>: POST <url> failed: <cause>" where cause is libcurl's text for the error code
// ("Couldn't connect to server", "Timeout was reached", "Transferred a partial file", ...). HTTP error
// statuses are returned, not thrown: the caller knows how its server words errors (see http_status_error).
// A body over the limit fails with "<who>: POST <url> failed: the response is larger than max_reply_bytes =
// N"; a call cancelled through a CancellationScope on this thread (polled about once a second) with
// "<who>: POST <url> cancelled: the run is stopping". URLs in messages are redacted; `secrets` are scrubbed
// from the body before it is sent (a secret never goes out as text) and from the response body.
HttpResponse post_json(const std::string& who, const std::string& url, const Json& body,
                       const std::vector<std::string>& headers, const HttpTimeouts& timeouts,
                       const HttpLimits& limits = {}, const Secrets& secrets = Secrets());

// "<who>: POST <url> returned HTTP <status>: <detail>", detail taken from an {"error": ...} body
// (string or {"message": ...}) when there is one, else the start of the body.
std::string http_status_error(const std::string& who, const std::string& url, long status,
                              const std::string& body);

// Parses a response body as JSON; throws hf::Error "<who>: POST <url>: response is not JSON: ..." or, for a
// body nested deeper than kMaxJsonDepth, "... response nests JSON N levels deep (at most 64)".
Json parse_response(const std::string& who, const std::string& url, const std::string& body);

// "host:port" or "http://host:port/" -> "http://host:port" (no trailing slash).
std::string normalize_base_url(const std::string& url);

}  // namespace hf::llm
