#include "http_handler.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>

#include "sha256.hpp"
#include "web_assets.hpp"

namespace mucosa::study::detail {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr std::size_t kImageCacheBytes = 256u << 20;  // keep stimuli in memory up to this
constexpr std::size_t kTokenHexDigits = 32;           // 128 bits (store.cpp, newToken)

std::string lower(std::string_view s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
    return out;
}

bool validObserverId(const std::string& s) {
    return !s.empty() && s.size() <= 64 && std::all_of(s.begin(), s.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
               c == '.';
    });
}

std::string mimeOf(const fs::path& p) {
    const std::string e = lower(p.extension().string());
    if (e == ".png") return "image/png";
    if (e == ".jpg" || e == ".jpeg") return "image/jpeg";
    if (e == ".webp") return "image/webp";
    if (e == ".gif") return "image/gif";
    if (e == ".svg") return "image/svg+xml";
    return "application/octet-stream";
}

std::string hashKey(std::string_view token) {
    const auto d = sha256(token);
    return std::string(reinterpret_cast<const char*>(d.data()), d.size());
}

int hexValue(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

// RFC 3986 percent-decoding of a query value ('+' is a space, as forms send it).
std::string percentDecode(std::string_view s) {
    std::string out;
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size() && hexValue(s[i + 1]) >= 0 && hexValue(s[i + 2]) >= 0) {
            out += static_cast<char>(hexValue(s[i + 1]) * 16 + hexValue(s[i + 2]));
            i += 2;
        } else {
            out += s[i] == '+' ? ' ' : s[i];
        }
    }
    return out;
}

// The first value of `key` in the query string, decoded.
std::optional<std::string> queryParam(std::string_view query, std::string_view key) {
    while (!query.empty()) {
        const std::size_t amp = query.find('&');
        const std::string_view pair = query.substr(0, amp);
        const std::size_t eq = pair.find('=');
        if (pair.substr(0, eq) == key) return percentDecode(eq == std::string_view::npos ? "" : pair.substr(eq + 1));
        if (amp == std::string_view::npos) break;
        query.remove_prefix(amp + 1);
    }
    return std::nullopt;
}

HttpResponse jsonResponse(int status, const json& j) {
    HttpResponse r;
    r.status = status;
    r.contentType = "application/json";
    // Replace, never throw, on invalid UTF-8 echoed from a request.
    r.body = j.dump(-1, ' ', false, json::error_handler_t::replace);
    r.headers.emplace_back("Cache-Control", "no-store");
    return r;
}

HttpResponse errorResponse(int status, const std::string& message) {
    return jsonResponse(status, json{{"error", message}});
}

// One answer for every request without a valid token: nothing in it tells
// which slots or observer ids exist.
HttpResponse unauthorized() {
    HttpResponse r = errorResponse(401, "this link is not valid");
    r.headers.emplace_back("WWW-Authenticate", "Bearer");
    return r;
}

// A client error thrown inside the handler: status and a message the page shows.
using ClientError = std::pair<int, std::string>;
constexpr int kUnauthorized = 401;  // thrown as a status; answered by unauthorized()

std::string stringField(const json& j, const char* key) {
    auto it = j.find(key);
    if (it == j.end() || !it->is_string()) throw ClientError{400, fmt::format("\"{}\" must be a string", key)};
    return it->get<std::string>();
}

}  // namespace

const std::string* HttpRequest::header(std::string_view name) const {
    for (const auto& [k, v] : headers)
        if (k.size() == name.size() && lower(k) == lower(name)) return &v;
    return nullptr;
}

HttpHandler::HttpHandler(const Plan& plan, AnswerStore& store, const std::vector<std::string>& tokens, std::string host)
    : plan_(plan), store_(store), host_(std::move(host)) {
    for (std::size_t i = 0; i < tokens.size(); ++i) slotByHash_.emplace(hashKey(tokens[i]), static_cast<int>(i));
}

// The slot whose token this is. The lookup is by the token's SHA-256, so its
// timing says nothing about how close a guess was; the found entry's hash is
// compared again in constant time.
std::optional<int> HttpHandler::slotOf(std::string_view token) const {
    if (token.size() != kTokenHexDigits) return std::nullopt;
    const std::string key = hashKey(token);
    const auto it = slotByHash_.find(key);
    if (it == slotByHash_.end()) return std::nullopt;
    std::array<std::uint8_t, 32> a{}, b{};
    std::copy(key.begin(), key.end(), a.begin());
    std::copy(it->first.begin(), it->first.end(), b.begin());
    if (!constantTimeEqual(a, b)) return std::nullopt;
    return it->second;
}

// The Host values this server answers to: its bound host:port, and the
// loopback aliases when bound to loopback. A page of another site that
// rebinds its DNS name to this address sends its own name and is refused.
// Bound to a wildcard address, the name observers use is unknown: any.
bool HttpHandler::hostAllowed(const std::string& hostHeader) const {
    const std::string& h = host_;
    if (h == "0.0.0.0" || h == "::" || h.empty()) return true;
    const std::string port = std::to_string(port_);
    std::vector<std::string> names{h};
    if (h == "127.0.0.1" || h == "localhost" || h == "::1") names = {"127.0.0.1", "localhost", "[::1]"};
    for (const std::string& n : names)
        if (hostHeader == n + ":" + port || (port == "80" && hostHeader == n)) return true;
    return false;
}

json HttpHandler::screenOf(const ObserverPlan& op, int trial) const {
    auto url = [](int image) { return "/image/" + std::to_string(image); };
    const Trial& t = op.trials[static_cast<std::size_t>(trial)];
    json s{{"kind", trialKindName(t.kind)}};
    if (t.kind == TrialKind::Likert) {
        int index = 0;  // position among the Likert trials
        for (int i = 0; i < trial; ++i) index += op.trials[static_cast<std::size_t>(i)].kind == TrialKind::Likert;
        const int count = op.likertCount(), series = plan_.options.seriesLength;
        s["image"] = url(t.image);
        s["index"] = index;
        s["count"] = count;
        s["series"] = index / series;
        s["series_count"] = (count + series - 1) / series;
        s["series_start"] = index > 0 && index % series == 0;
    } else {
        s["left"] = url(t.left);
        s["right"] = url(t.right);
        if (t.kind == TrialKind::TwoAfc) {
            int index = 0, count = 0;
            for (std::size_t i = 0; i < op.trials.size(); ++i)
                if (op.trials[i].kind == TrialKind::TwoAfc) {
                    index += static_cast<int>(i) < trial;
                    ++count;
                }
            s["index"] = index;
            s["count"] = count;
        }
    }
    return s;
}

json HttpHandler::stateOf(const ObserverRow& o) {
    const ObserverPlan& op = plan_.observers[static_cast<std::size_t>(o.slot)];
    const int next = store_.answeredCount(o.id);
    const int total = static_cast<int>(op.trials.size());
    json j{{"registered", true}, {"observer", o.id}, {"group", o.group},
           {"trial", next},      {"total", total},   {"done", next >= total}};
    if (next < total) {
        j["screen"] = screenOf(op, next);
        json preload = json::array();  // the following screen's images, fetched while this one is rated
        if (next + 1 < total) {
            const Trial& t = op.trials[static_cast<std::size_t>(next + 1)];
            for (int i : {t.image, t.left, t.right})
                if (i >= 0) preload.push_back("/image/" + std::to_string(i));
        }
        j["preload"] = preload;
    }
    return j;
}

namespace {

json parseBody(const std::string& body) {
    if (body.size() > kBodyLimit) throw ClientError{413, "request too large"};
    try {
        json j = json::parse(body);
        if (!j.is_object()) throw ClientError{400, "expected a JSON object"};
        return j;
    } catch (const json::exception& e) {
        // parse_error, but also out_of_range for numbers such as 1e999.
        throw ClientError{400, std::string("malformed JSON: ") + e.what()};
    }
}

std::optional<std::int64_t> timeField(const json& j, const char* key) {
    auto it = j.find(key);
    if (it == j.end() || it->is_null()) return std::nullopt;
    if (!it->is_number()) throw ClientError{400, fmt::format("\"{}\" must be a number (ms since 1970)", key)};
    const double v = it->get<double>();
    if (!(v >= 0 && v < 1e15)) throw ClientError{400, fmt::format("\"{}\" is out of range", key)};
    return static_cast<std::int64_t>(v);
}

}  // namespace

// The observer bound to `slot`. A request that names an observer must name
// that one: another slot's id is refused like a wrong token.
ObserverRow HttpHandler::requireBound(int slot, const std::string* observer) {
    auto o = store_.observerInSlot(slot);
    if (observer && (!o || *observer != o->id)) throw ClientError{kUnauthorized, ""};
    if (!o) throw ClientError{409, "this link has no observer yet: start the study first"};
    return *o;
}

json HttpHandler::session(int slot, const json& b) {
    const std::string id = stringField(b, "observer"), group = stringField(b, "group");
    if (!validObserverId(id)) throw ClientError{400, "observer id: 1-64 letters, digits, '.', '_' or '-'"};
    if (group != "naive" && group != "expert") throw ClientError{400, "group must be naive or expert"};
    auto o = store_.claimSlot(slot, id, group);
    if (!o) throw ClientError{kUnauthorized, ""};  // this link belongs to another id, or the id to another link
    if (o->group != group)
        throw ClientError{409, fmt::format("observer '{}' is registered in the {} group", id, o->group)};
    return stateOf(*o);
}

json HttpHandler::answer(int slot, const json& b) {
    const auto given = b.find("observer");
    std::string named;
    if (given != b.end()) named = stringField(b, "observer");
    const ObserverRow o = requireBound(slot, given != b.end() ? &named : nullptr);
    const ObserverPlan& op = plan_.observers[static_cast<std::size_t>(o.slot)];
    auto tr = b.find("trial");
    if (tr == b.end() || !tr->is_number_integer()) throw ClientError{400, "\"trial\" must be an integer"};
    const long long trial = tr->get<long long>();
    if (trial < 0 || trial >= static_cast<long long>(op.trials.size()))
        throw ClientError{400, "\"trial\" is outside this observer's plan"};
    const Trial& t = op.trials[static_cast<std::size_t>(trial)];

    AnswerRow a;
    a.observer = o.id;
    a.group = o.group;
    a.trial = static_cast<int>(trial);
    a.kind = trialKindName(t.kind);
    a.shownAtMs = timeField(b, "shown_at_ms");
    a.answeredAtMs = timeField(b, "answered_at_ms");
    const auto ans = b.find("answer");
    if (ans == b.end()) throw ClientError{400, "\"answer\" is missing"};
    auto image = [&](int i) -> const Image& { return plan_.images[static_cast<std::size_t>(i)]; };
    switch (t.kind) {
        case TrialKind::Calibration:
            if (*ans != "seen") throw ClientError{400, "the calibration screen's answer is \"seen\""};
            a.answer = "seen";
            a.leftId = image(t.left).id;
            a.leftCategory = image(t.left).category;
            a.rightId = image(t.right).id;
            a.rightCategory = image(t.right).category;
            break;
        case TrialKind::Likert: {
            // Exactly an integer 1-5: 3.5, "3", -4294967295 or 4294967299 are refused, never truncated.
            if (!ans->is_number_integer() || ans->get<long long>() < 1 || ans->get<long long>() > 5)
                throw ClientError{400, "a Likert answer is an integer score 1-5"};
            const int score = static_cast<int>(ans->get<long long>());
            a.answer = std::to_string(score);
            a.score = score;
            a.imageId = image(t.image).id;
            a.category = image(t.image).category;
            break;
        }
        case TrialKind::TwoAfc: {
            if (*ans != "left" && *ans != "right") throw ClientError{400, "a 2AFC answer is \"left\" or \"right\""};
            a.answer = ans->get<std::string>();
            a.leftId = image(t.left).id;
            a.leftCategory = image(t.left).category;
            a.rightId = image(t.right).id;
            a.rightCategory = image(t.right).category;
            a.chosenCategory = a.answer == "left" ? a.leftCategory : a.rightCategory;
            break;
        }
    }
    switch (store_.insert(a)) {
        case AnswerStore::Insert::Stored:
        case AnswerStore::Insert::Duplicate:
            break;
        case AnswerStore::Insert::Conflict:
            throw ClientError{409, "this screen was already answered differently; the first answer is kept"};
        case AnswerStore::Insert::OutOfOrder:
            throw ClientError{409, "not the observer's current screen (answered elsewhere?)"};
    }
    return stateOf(o);
}

std::shared_ptr<const std::string> HttpHandler::imageBytes(int index) {
    {
        std::lock_guard lock(cacheMutex_);
        if (auto it = imageCache_.find(index); it != imageCache_.end()) return it->second;
    }
    const fs::path& file = plan_.images[static_cast<std::size_t>(index)].file;
    std::ifstream in(file, std::ios::binary);
    if (!in) return nullptr;
    std::ostringstream ss;
    ss << in.rdbuf();
    auto bytes = std::make_shared<const std::string>(ss.str());
    std::lock_guard lock(cacheMutex_);
    if (cachedBytes_ + bytes->size() <= kImageCacheBytes && imageCache_.emplace(index, bytes).second)
        cachedBytes_ += bytes->size();
    return bytes;
}

HttpResponse HttpHandler::handle(const HttpRequest& req) {
    try {
        return route(req);
    } catch (const ClientError& e) {
        return e.first == kUnauthorized ? unauthorized() : errorResponse(e.first, e.second);
    } catch (const mucosa::Error& e) {
        // Database trouble (disk full, I/O error): the answer was not stored;
        // the page keeps it and retries.
        return errorResponse(503, std::string("server could not store the answer: ") + e.what());
    } catch (const std::exception&) {
        return errorResponse(500, "internal error");
    }
}

HttpResponse HttpHandler::route(const HttpRequest& req) {
    // Host, Origin and Content-Type, before any route: 403 for another host or
    // origin, 415 for a POST that is not JSON (a cross-site form or a
    // `text/plain` fetch cannot send application/json without a CORS
    // preflight, which this server never grants).
    const std::string* hostHeader = req.header("Host");
    const std::string host = hostHeader ? *hostHeader : "";
    if (!hostAllowed(host)) return errorResponse(403, "wrong Host header");
    if (const std::string* origin = req.header("Origin"); origin && *origin != "http://" + host)
        return errorResponse(403, "cross-origin requests are refused");
    const bool post = req.method == "POST";
    if (post || req.method == "PUT" || req.method == "PATCH" || req.method == "DELETE") {
        const std::string* ct = req.header("Content-Type");
        std::string type = lower(ct ? ct->substr(0, ct->find(';')) : "");
        while (!type.empty() && type.back() == ' ') type.pop_back();
        if (type != "application/json") return errorResponse(415, "requests must be Content-Type: application/json");
    }

    const std::size_t q = req.target.find('?');
    const std::string path = req.target.substr(0, q);
    const std::string_view query =
        q == std::string::npos ? std::string_view() : std::string_view(req.target).substr(q + 1);
    const bool get = req.method == "GET";
    auto wrongMethod = [](const char* allow) {
        HttpResponse r = errorResponse(405, "method not allowed");
        r.headers.emplace_back("Allow", allow);
        return r;
    };

    // The page itself needs no token: it says so when its link is not valid.
    for (const auto& asset : webAssets()) {
        if (path != (asset.path == "index.html" ? "/" : "/" + asset.path)) continue;
        if (!get) return wrongMethod("GET");
        HttpResponse r;
        r.contentType = asset.mime;
        r.body.assign(asset.data, asset.size);
        r.headers.emplace_back("Cache-Control", "no-cache");
        r.headers.emplace_back("Referrer-Policy", "no-referrer");  // the link's token stays here
        return r;
    }

    const bool api = path == "/api/session" || path == "/api/answer" || path == "/api/state";
    const bool image = path.rfind("/image/", 0) == 0;
    if (!api && !image) {
        HttpResponse r;
        r.status = 404;
        r.contentType = "text/plain";
        r.body = "error 404";
        return r;
    }
    // Every route that reads or writes study data: a valid token first.
    // "Authorization: Bearer <token>" (the page's API calls) or ?t=<token> (its images).
    std::optional<std::string> token;
    if (const std::string* auth = req.header("Authorization"); auth && lower(auth->substr(0, 7)) == "bearer ")
        token = auth->substr(7);
    else
        token = queryParam(query, "t");
    const std::optional<int> slot = token ? slotOf(*token) : std::nullopt;
    if (!slot) return unauthorized();

    if (image) {
        if (!get) return wrongMethod("GET");
        // Only the plan's images, by index: a request never names a path.
        const std::string digits = path.substr(7);
        if (digits.empty() || digits.size() > 9 ||
            !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
            return errorResponse(404, "no such image");
        const long index = std::stol(digits);
        if (index >= static_cast<long>(plan_.images.size())) return errorResponse(404, "no such image");
        auto bytes = imageBytes(static_cast<int>(index));
        if (!bytes) return errorResponse(404, "image file missing on the server");
        HttpResponse r;
        r.contentType = mimeOf(plan_.images[static_cast<std::size_t>(index)].file);
        r.body = *bytes;
        r.headers.emplace_back("Cache-Control", "private, max-age=3600");
        return r;
    }
    if (path == "/api/state") {
        if (!get) return wrongMethod("GET");
        const std::optional<std::string> observer = queryParam(query, "observer");
        if (!observer) {  // the page asks where its link stands
            const auto o = store_.observerInSlot(*slot);
            return jsonResponse(200, o ? stateOf(*o) : json{{"registered", false}});
        }
        return jsonResponse(200, stateOf(requireBound(*slot, &*observer)));
    }
    if (!post) return wrongMethod("POST");
    const json b = parseBody(req.body);
    return jsonResponse(200, path == "/api/session" ? session(*slot, b) : answer(*slot, b));
}

}  // namespace mucosa::study::detail
