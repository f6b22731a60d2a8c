// libcurl-backed JSON POST shared by the ollama and openai providers.
#include "hazardforge/llm/http.hpp"

#include <curl/curl.h>

#include <algorithm>
#include <cctype>
#include <memory>
#include <mutex>

#include <hazardforge/error.hpp>
#include <hazardforge/json_text.hpp>
#include <hazardforge/redact.hpp>
#include <hazardforge/run_signals.hpp>

namespace hf::llm {

namespace {

struct BodySink {
  std::string* body = nullptr;
  size_t max = 0;
  bool exceeded = false;
};

// Stops the transfer as soon as the body would pass the limit: a server streaming without end never gets to
// allocate more than the limit.
size_t append_body(char* data, size_t size, size_t n, void* user) {
  auto* sink = static_cast<BodySink*>(user);
  if (sink->body->size() + size * n > sink->max) {
    sink->exceeded = true;
    return 0;
  }
  sink->body->append(data, size * n);
  return size * n;
}

// Runs on the calling thread about once a second even while the server is silent, so a stage's
// CancellationScope (Ctrl-C) ends a call that would otherwise wait for its read timeout.
int on_progress(void*, curl_off_t, curl_off_t, curl_off_t, curl_off_t) {
  return cancellation_requested() ? 1 : 0;
}

// curl_global_init is not thread-safe; run it once for the process.
void init_curl_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) throw Error("libcurl: curl_global_init failed");
  });
}

long to_ms(double seconds) {
  return seconds <= 0 ? 0L : static_cast<long>(seconds * 1000.0 + 0.5);
}

std::string percent_decoded(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

std::string base64(const std::string& s) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < s.size(); i += 3) {
    const unsigned v = static_cast<unsigned char>(s[i]) << 16 | static_cast<unsigned char>(s[i + 1]) << 8 |
                       static_cast<unsigned char>(s[i + 2]);
    for (int k = 18; k >= 0; k -= 6) out += kAlphabet[(v >> k) & 63];
  }
  if (i < s.size()) {
    unsigned v = static_cast<unsigned char>(s[i]) << 16;
    if (i + 1 < s.size()) v |= static_cast<unsigned char>(s[i + 1]) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < s.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace

void Secrets::add(const std::string& value) {
  if (value.size() < 4 || std::find(values_.begin(), values_.end(), value) != values_.end()) return;
  values_.push_back(value);
  std::stable_sort(values_.begin(), values_.end(),
                   [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
}

void Secrets::add_url_credentials(const std::string& url) {
  const size_t sep = url.find("://");
  const size_t start = sep == std::string::npos ? 0 : sep + 3;
  const size_t end = url.find_first_of("/?#", start);
  const std::string authority = url.substr(start, end == std::string::npos ? std::string::npos : end - start);
  const size_t at = authority.rfind('@');
  if (at == std::string::npos) return;
  const std::string userinfo = authority.substr(0, at);
  const std::string decoded = percent_decoded(userinfo);
  const size_t colon = userinfo.find(':');
  if (colon != std::string::npos) {
    add(userinfo.substr(colon + 1));
    add(percent_decoded(userinfo.substr(colon + 1)));
  }
  add(userinfo);
  add(decoded);
  add(base64(colon == std::string::npos ? decoded + ":" : decoded));  // what libcurl sends as Basic
}

std::string Secrets::scrub(std::string text) const {
  for (const std::string& v : values_)
    for (size_t p = text.find(v); p != std::string::npos; p = text.find(v, p + 3))
      text.replace(p, v.size(), "***");
  return text;
}

Json Secrets::scrub(const Json& j) const {
  if (values_.empty()) return j;
  if (j.is_string()) return scrub(j.get<std::string>());
  if (j.is_array()) {
    Json a = Json::array();
    for (const Json& e : j) a.push_back(scrub(e));
    return a;
  }
  if (j.is_object()) {
    Json o = Json::object();
    for (auto it = j.begin(); it != j.end(); ++it) o[scrub(it.key())] = scrub(it.value());
    return o;
  }
  return j;
}

HttpResponse post_json(const std::string& who, const std::string& url, const Json& body,
                       const std::vector<std::string>& headers, const HttpTimeouts& timeouts,
                       const HttpLimits& limits, const Secrets& secrets) {
  init_curl_once();
  std::unique_ptr<CURL, void (*)(CURL*)> curl(curl_easy_init(), curl_easy_cleanup);
  if (!curl) throw Error(who + ": POST " + redact_urls(url) + " failed: curl_easy_init returned null");
  curl_slist* list = curl_slist_append(nullptr, "Content-Type: application/json");
  list = curl_slist_append(list, "Accept: application/json");
  for (const std::string& h : headers) list = curl_slist_append(list, h.c_str());
  std::unique_ptr<curl_slist, void (*)(curl_slist*)> header_list(list, curl_slist_free_all);

  const std::string payload = json_text(secrets.scrub(body));
  HttpResponse res;
  CURL* c = curl.get();
  curl_easy_setopt(c, CURLOPT_URL, url.c_str());
  curl_easy_setopt(c, CURLOPT_POST, 1L);
  curl_easy_setopt(c, CURLOPT_POSTFIELDS, payload.c_str());
  curl_easy_setopt(c, CURLOPT_POSTFIELDSIZE_LARGE, static_cast<curl_off_t>(payload.size()));
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, header_list.get());
  BodySink sink{&res.body, limits.max_body_bytes};
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, &append_body);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &sink);
  // Refuses a declared Content-Length over the limit before any of the body is read.
  curl_easy_setopt(c, CURLOPT_MAXFILESIZE_LARGE, static_cast<curl_off_t>(limits.max_body_bytes));
  curl_easy_setopt(c, CURLOPT_NOPROGRESS, 0L);
  curl_easy_setopt(c, CURLOPT_XFERINFOFUNCTION, &on_progress);
  curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, to_ms(timeouts.connect_s));
  curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, to_ms(timeouts.read_s));
  // Signals cannot be used for timeouts in a multi-threaded host.
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
  // An LLM endpoint never redirects legitimately; following one could send the prompt elsewhere.
  curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 0L);
  // A proxy from the environment must not intercept loopback model servers.
  curl_easy_setopt(c, CURLOPT_NOPROXY, "127.0.0.1,localhost,::1");

  CURLcode rc = curl_easy_perform(c);
  const std::string post = who + ": POST " + redact_urls(url);
  if (rc == CURLE_FILESIZE_EXCEEDED || (rc == CURLE_WRITE_ERROR && sink.exceeded))
    throw Error(post + " failed: the response is larger than max_reply_bytes = " +
                std::to_string(limits.max_body_bytes));
  if (rc == CURLE_ABORTED_BY_CALLBACK) throw Error(post + " cancelled: the run is stopping");
  if (rc != CURLE_OK) throw Error(post + " failed: " + curl_easy_strerror(rc));
  curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &res.status);
  res.body = secrets.scrub(std::move(res.body));
  return res;
}

std::string http_status_error(const std::string& who, const std::string& url, long status,
                              const std::string& body) {
  std::string detail;
  Json j = Json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("error")) {
    const Json& e = j["error"];
    if (e.is_string())
      detail = e.get<std::string>();
    else if (e.is_object() && e.contains("message") && e["message"].is_string())
      detail = e["message"];
    else
      detail = json_text(e);
  } else {
    constexpr size_t kMax = 200;
    detail = body.size() > kMax ? body.substr(0, kMax) + "..." : body;
    if (detail.empty()) detail = "(empty body)";
  }
  return who + ": POST " + redact_urls(url) + " returned HTTP " + std::to_string(status) + ": " + detail;
}

Json parse_response(const std::string& who, const std::string& url, const std::string& body) {
  if (const int depth = json_nesting_depth(body); depth > kMaxJsonDepth)
    throw Error(who + ": POST " + redact_urls(url) + ": response nests JSON " + std::to_string(depth) +
                " levels deep (at most " + std::to_string(kMaxJsonDepth) + ")");
  try {
    return Json::parse(body);
  } catch (const Json::exception& e) {  // parse errors and numbers too large for a double
    std::string what = e.what();
    if (auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw Error(who + ": POST " + redact_urls(url) + ": response is not JSON: " + what);
  }
}

std::string normalize_base_url(const std::string& url) {
  std::string u = url;
  if (u.find("://") == std::string::npos) u = "http://" + u;
  while (!u.empty() && u.back() == '/') u.pop_back();
  return u;
}

}  // namespace hf::llm
