// JSON-over-HTTP POST for the LLM providers (libcurl), with connect/read timeouts and uniform error texts.
#pragma once

#include <string>
#include <vector>

#include <hazardforge/error.hpp>
#include <hazardforge/types.hpp>

namespace hf::llm {

struct HttpTimeouts {
  double connect_s = 5.0;  // TCP connect
  double read_s = 300.0;   // whole request after the call starts (local models answer slowly)
};

struct HttpResponse {
  long status = 0;
  std::string body;
};

// POSTs `body` as application/json. `who` prefixes every message (e.g. "ollama"). Transport failures throw
// hf::Error "<who>: POST <url> failed: <cause>" where cause is libcurl's text for the error code
// ("Couldn't connect to server", "Timeout was reached", "Transferred a partial file", ...). HTTP error
// statuses are returned, not thrown: the caller knows how its server words errors (see http_status_error).
HttpResponse post_json(const std::string& who, const std::string& url, const Json& body,
                       const std::vector<std::string>& headers, const HttpTimeouts& timeouts);

// "<who>: POST <url> returned HTTP <status>: <detail>", detail taken from an {"error": ...} body
// (string or {"message": ...}) when there is one, else the start of the body.
std::string http_status_error(const std::string& who, const std::string& url, long status,
                              const std::string& body);

// Parses a response body as JSON; throws hf::Error "<who>: POST <url>: response is not JSON: ...".
Json parse_response(const std::string& who, const std::string& url, const std::string& body);

// "host:port" or "http://host:port/" -> "http://host:port" (no trailing slash).
std::string normalize_base_url(const std::string& url);

}  // namespace hf::llm
