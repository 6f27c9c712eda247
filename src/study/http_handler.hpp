#pragma once
// The study server's request handling, independent of the transport: a parsed
// request in, a response out, no sockets. server.cpp feeds it from Boost.Beast;
// fuzz/fuzz_study_http.cpp feeds it arbitrary requests.
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <mucosa/study/plan.hpp>

#include "store.hpp"

namespace mucosa::study::detail {

// Limits of one request (the transport enforces them while parsing, chunked
// bodies included; the handler checks the body again).
constexpr std::size_t kHeaderLimit = 8 * 1024;
constexpr std::size_t kBodyLimit = 16 * 1024;  // an answer is ~200 bytes

struct HttpRequest {
    std::string method, target, body;
    std::vector<std::pair<std::string, std::string>> headers;  // as received, in order
    std::string peer;                                          // client address, for logs and limits

    // The first header of that name (case-insensitive), or nullptr.
    const std::string* header(std::string_view name) const;
};

struct HttpResponse {
    int status = 200;
    std::string contentType, body;
    std::vector<std::pair<std::string, std::string>> headers;
};

class HttpHandler {
public:
    // `tokens[i]` is observer slot i's secret; `host` the address the server
    // is bound to (for the Host check).
    HttpHandler(const Plan& plan, AnswerStore& store, const std::vector<std::string>& tokens, std::string host);
    void setPort(int port) { port_ = port; }  // the bound port, before the first request

    // Thread-safe; never throws for any request (errors become responses).
    HttpResponse handle(const HttpRequest& req);

private:
    bool hostAllowed(const std::string& host) const;
    std::optional<int> slotOf(std::string_view token) const;
    HttpResponse route(const HttpRequest& req);
    ObserverRow requireBound(int slot, const std::string* observer);
    nlohmann::json screenOf(const ObserverPlan& op, int trial) const;
    nlohmann::json stateOf(const ObserverRow& o);
    nlohmann::json session(int slot, const nlohmann::json& body);
    nlohmann::json answer(int slot, const nlohmann::json& body);
    std::shared_ptr<const std::string> imageBytes(int index);

    const Plan& plan_;
    AnswerStore& store_;
    std::string host_;
    int port_ = 0;
    std::unordered_map<std::string, int> slotByHash_;  // SHA-256 of a token -> slot
    std::mutex cacheMutex_;
    std::map<int, std::shared_ptr<const std::string>> imageCache_;
    std::size_t cachedBytes_ = 0;
};

}  // namespace mucosa::study::detail
