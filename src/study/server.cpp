#include <mucosa/study/server.hpp>

#include <sys/socket.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>

#include "store.hpp"
#include "web_assets.hpp"

namespace mucosa::study {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr std::size_t kMaxBody = 16 * 1024;           // an answer is ~200 bytes
constexpr int kListenBacklog = 1024;                  // pending connections (clamped to somaxconn)
constexpr std::size_t kImageCacheBytes = 256u << 20;  // keep stimuli in memory up to this

bool validObserverId(const std::string& s) {
    return !s.empty() && s.size() <= 64 && std::all_of(s.begin(), s.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
               c == '.';
    });
}

std::string mimeOf(const fs::path& p) {
    std::string e = p.extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
    if (e == ".png") return "image/png";
    if (e == ".jpg" || e == ".jpeg") return "image/jpeg";
    if (e == ".webp") return "image/webp";
    if (e == ".gif") return "image/gif";
    if (e == ".svg") return "image/svg+xml";
    return "application/octet-stream";
}

// A client error: status and a message the page shows.
struct HttpError {
    int status;
    std::string message;
};

}  // namespace

struct StudyServer::Impl {
    Plan plan;
    ServeOptions options;
    detail::AnswerStore store;
    httplib::Server http;
    std::mutex cacheMutex;
    std::map<int, std::shared_ptr<const std::string>> imageCache;
    std::size_t cachedBytes = 0;
    int listenSocket = -1;
    std::mutex stopMutex;
    std::condition_variable stopCv;
    bool stopRequested = false;

    Impl(Plan p, ServeOptions o) : plan(std::move(p)), options(std::move(o)), store(options.db, plan.fingerprint) {}

    static std::string url(int image) { return "/image/" + std::to_string(image); }

    json screenOf(const ObserverPlan& op, int trial) const {
        const Trial& t = op.trials[static_cast<std::size_t>(trial)];
        json s{{"kind", trialKindName(t.kind)}};
        if (t.kind == TrialKind::Likert) {
            int index = 0;  // position among the Likert trials
            for (int i = 0; i < trial; ++i) index += op.trials[static_cast<std::size_t>(i)].kind == TrialKind::Likert;
            const int count = op.likertCount(), series = plan.options.seriesLength;
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

    json stateOf(const detail::ObserverRow& o) {
        const ObserverPlan& op = plan.observers[static_cast<std::size_t>(o.slot)];
        const int next = store.answeredCount(o.id);
        const int total = static_cast<int>(op.trials.size());
        json j{{"observer", o.id}, {"group", o.group}, {"trial", next}, {"total", total}, {"done", next >= total}};
        if (next < total) {
            j["screen"] = screenOf(op, next);
            json preload = json::array();  // the following screen's images, fetched while this one is rated
            if (next + 1 < total) {
                const Trial& t = op.trials[static_cast<std::size_t>(next + 1)];
                for (int i : {t.image, t.left, t.right})
                    if (i >= 0) preload.push_back(url(i));
            }
            j["preload"] = preload;
        }
        return j;
    }

    static json parseBody(const httplib::Request& req) {
        if (req.body.size() > kMaxBody) throw HttpError{413, "request too large"};
        try {
            json j = json::parse(req.body);
            if (!j.is_object()) throw HttpError{400, "expected a JSON object"};
            return j;
        } catch (const json::exception& e) {
            // parse_error, but also out_of_range for numbers such as 1e999.
            throw HttpError{400, std::string("malformed JSON: ") + e.what()};
        }
    }

    static std::string stringField(const json& j, const char* key) {
        auto it = j.find(key);
        if (it == j.end() || !it->is_string()) throw HttpError{400, fmt::format("\"{}\" must be a string", key)};
        return it->get<std::string>();
    }

    static std::optional<std::int64_t> timeField(const json& j, const char* key) {
        auto it = j.find(key);
        if (it == j.end() || it->is_null()) return std::nullopt;
        if (!it->is_number()) throw HttpError{400, fmt::format("\"{}\" must be a number (ms since 1970)", key)};
        const double v = it->get<double>();
        if (!(v >= 0 && v < 1e15)) throw HttpError{400, fmt::format("\"{}\" is out of range", key)};
        return static_cast<std::int64_t>(v);
    }

    detail::ObserverRow requireObserver(const std::string& id) {
        if (!validObserverId(id)) throw HttpError{400, "observer id: 1-64 letters, digits, '.', '_' or '-'"};
        auto o = store.findObserver(id);
        if (!o) throw HttpError{404, "unknown observer '" + id + "'"};
        return *o;
    }

    json session(const httplib::Request& req) {
        const json b = parseBody(req);
        const std::string id = stringField(b, "observer"), group = stringField(b, "group");
        if (!validObserverId(id)) throw HttpError{400, "observer id: 1-64 letters, digits, '.', '_' or '-'"};
        if (group != "naive" && group != "expert") throw HttpError{400, "group must be naive or expert"};
        auto o = store.addObserver(id, group, static_cast<int>(plan.observers.size()));
        if (!o)
            throw HttpError{409, fmt::format("all {} planned observer slots are taken (plan more with --observers)",
                                             plan.observers.size())};
        if (o->group != group)
            throw HttpError{409, fmt::format("observer '{}' is registered in the {} group", id, o->group)};
        return stateOf(*o);
    }

    json answer(const httplib::Request& req) {
        const json b = parseBody(req);
        const detail::ObserverRow o = requireObserver(stringField(b, "observer"));
        const ObserverPlan& op = plan.observers[static_cast<std::size_t>(o.slot)];
        auto tr = b.find("trial");
        if (tr == b.end() || !tr->is_number_integer()) throw HttpError{400, "\"trial\" must be an integer"};
        const long long trial = tr->get<long long>();
        if (trial < 0 || trial >= static_cast<long long>(op.trials.size()))
            throw HttpError{400, "\"trial\" is outside this observer's plan"};
        const Trial& t = op.trials[static_cast<std::size_t>(trial)];

        detail::AnswerRow a;
        a.observer = o.id;
        a.group = o.group;
        a.trial = static_cast<int>(trial);
        a.kind = trialKindName(t.kind);
        a.shownAtMs = timeField(b, "shown_at_ms");
        a.answeredAtMs = timeField(b, "answered_at_ms");
        const auto ans = b.find("answer");
        if (ans == b.end()) throw HttpError{400, "\"answer\" is missing"};
        auto image = [&](int i) -> const Image& { return plan.images[static_cast<std::size_t>(i)]; };
        switch (t.kind) {
            case TrialKind::Calibration:
                if (*ans != "seen") throw HttpError{400, "the calibration screen's answer is \"seen\""};
                a.answer = "seen";
                a.leftId = image(t.left).id;
                a.leftCategory = image(t.left).category;
                a.rightId = image(t.right).id;
                a.rightCategory = image(t.right).category;
                break;
            case TrialKind::Likert: {
                // Exactly an integer 1-5: 3.5, "3", -4294967295 or 4294967299 are refused, never truncated.
                if (!ans->is_number_integer() || ans->get<long long>() < 1 || ans->get<long long>() > 5)
                    throw HttpError{400, "a Likert answer is an integer score 1-5"};
                const int score = static_cast<int>(ans->get<long long>());
                a.answer = std::to_string(score);
                a.score = score;
                a.imageId = image(t.image).id;
                a.category = image(t.image).category;
                break;
            }
            case TrialKind::TwoAfc: {
                if (*ans != "left" && *ans != "right") throw HttpError{400, "a 2AFC answer is \"left\" or \"right\""};
                a.answer = ans->get<std::string>();
                a.leftId = image(t.left).id;
                a.leftCategory = image(t.left).category;
                a.rightId = image(t.right).id;
                a.rightCategory = image(t.right).category;
                a.chosenCategory = a.answer == "left" ? a.leftCategory : a.rightCategory;
                break;
            }
        }
        switch (store.insert(a)) {
            case detail::AnswerStore::Insert::Stored:
            case detail::AnswerStore::Insert::Duplicate:
                break;
            case detail::AnswerStore::Insert::Conflict:
                throw HttpError{409, "this screen was already answered differently; the first answer is kept"};
            case detail::AnswerStore::Insert::OutOfOrder:
                throw HttpError{409, "not the observer's current screen (answered elsewhere?)"};
        }
        return stateOf(o);
    }

    std::shared_ptr<const std::string> imageBytes(int index) {
        {
            std::lock_guard lock(cacheMutex);
            if (auto it = imageCache.find(index); it != imageCache.end()) return it->second;
        }
        const fs::path& file = plan.images[static_cast<std::size_t>(index)].file;
        std::ifstream in(file, std::ios::binary);
        if (!in) throw HttpError{404, "image file missing on the server"};
        std::ostringstream ss;
        ss << in.rdbuf();
        auto bytes = std::make_shared<const std::string>(ss.str());
        std::lock_guard lock(cacheMutex);
        if (cachedBytes + bytes->size() <= kImageCacheBytes) {
            imageCache.emplace(index, bytes);
            cachedBytes += bytes->size();
        }
        return bytes;
    }

    template <class F>
    httplib::Server::Handler api(F&& f) {
        return [this, f](const httplib::Request& req, httplib::Response& res) {
            try {
                res.set_content(f(req).dump(), "application/json");
            } catch (const HttpError& e) {
                res.status = e.status;
                res.set_content(json{{"error", e.message}}.dump(), "application/json");
            } catch (const Error& e) {
                // Database trouble (disk full, I/O error): the answer was not
                // stored; the page keeps it and retries.
                res.status = 503;
                res.set_content(json{{"error", std::string("server could not store the answer: ") + e.what()}}.dump(),
                                "application/json");
            }
            res.set_header("Cache-Control", "no-store");
        };
    }

    std::atomic<int> boundPort{0};

    // The Host values this server answers to: its bound host:port, and the
    // loopback aliases when bound to loopback. A page of another site that
    // rebinds its DNS name to this address sends its own name and is refused.
    // Bound to a wildcard address, the name observers use is unknown: any.
    bool hostAllowed(const std::string& hostHeader) const {
        const std::string& h = options.host;
        if (h == "0.0.0.0" || h == "::" || h.empty()) return true;
        const std::string port = std::to_string(boundPort.load());
        std::vector<std::string> names{h};
        if (h == "127.0.0.1" || h == "localhost" || h == "::1") names = {"127.0.0.1", "localhost", "[::1]"};
        for (const std::string& n : names)
            if (hostHeader == n + ":" + port || (port == "80" && hostHeader == n)) return true;
        return false;
    }

    // Host, Origin and Content-Type, before any route: 403 for another host or
    // origin, 415 for a POST that is not JSON (a cross-site form or a
    // `text/plain` fetch cannot send application/json without a CORS
    // preflight, which this server never grants).
    httplib::Server::HandlerResponse screen(const httplib::Request& req, httplib::Response& res) const {
        auto refuse = [&](int status, const std::string& message) {
            res.status = status;
            res.set_content(json{{"error", message}}.dump(), "application/json");
            return httplib::Server::HandlerResponse::Handled;
        };
        const std::string host = req.get_header_value("Host");
        if (!hostAllowed(host)) return refuse(403, "wrong Host header");
        if (req.has_header("Origin") && req.get_header_value("Origin") != "http://" + host)
            return refuse(403, "cross-origin requests are refused");
        if (req.method == "POST" || req.method == "PUT" || req.method == "PATCH" || req.method == "DELETE") {
            std::string type = req.get_header_value("Content-Type");
            type = type.substr(0, type.find(';'));
            std::transform(type.begin(), type.end(), type.begin(), [](unsigned char c) { return std::tolower(c); });
            while (!type.empty() && type.back() == ' ') type.pop_back();
            if (type != "application/json") return refuse(415, "requests must be Content-Type: application/json");
        }
        return httplib::Server::HandlerResponse::Unhandled;
    }

    void routes() {
        http.set_pre_routing_handler(
            [this](const httplib::Request& req, httplib::Response& res) { return screen(req, res); });
        for (const auto& asset : detail::webAssets()) {
            const std::string path = asset.path == "index.html" ? "/" : "/" + asset.path;
            http.Get(path, [&asset](const httplib::Request&, httplib::Response& res) {
                res.set_content(asset.data, asset.size, asset.mime);
                res.set_header("Cache-Control", "no-cache");
            });
        }
        http.Post("/api/session", api([this](const httplib::Request& r) { return session(r); }));
        http.Post("/api/answer", api([this](const httplib::Request& r) { return answer(r); }));
        http.Get("/api/state", api([this](const httplib::Request& r) {
                     if (!r.has_param("observer")) throw HttpError{400, "?observer= is missing"};
                     return stateOf(requireObserver(r.get_param_value("observer")));
                 }));
        // Only the plan's images, by index: a request never names a path.
        http.Get(R"(/image/(\d{1,9}))", [this](const httplib::Request& req, httplib::Response& res) {
            const long index = std::stol(req.matches[1].str());
            if (index >= static_cast<long>(plan.images.size())) {
                res.status = 404;
                res.set_content("no such image", "text/plain");
                return;
            }
            try {
                auto bytes = imageBytes(static_cast<int>(index));
                res.set_content(bytes->data(), bytes->size(),
                                mimeOf(plan.images[static_cast<std::size_t>(index)].file));
                res.set_header("Cache-Control", "private, max-age=3600");
            } catch (const HttpError& e) {
                res.status = e.status;
                res.set_content(e.message, "text/plain");
            }
        });
        http.set_error_handler([](const httplib::Request&, httplib::Response& res) {
            if (res.body.empty()) res.set_content(fmt::format("error {}", res.status), "text/plain");
        });
        http.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
            res.status = 500;
            res.set_content("internal error", "text/plain");
        });
    }
};

StudyServer::StudyServer(Plan plan, ServeOptions options) {
    if (options.db.empty()) throw InputError("database", "", "give --db answers.sqlite");
    if (options.port < 0 || options.port > 65535) throw InputError("port", "", "must be 0..65535");
    impl_ = std::make_unique<Impl>(std::move(plan), std::move(options));
    const int threads = impl_->options.threads > 0 ? impl_->options.threads : 64;
    impl_->http.new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<std::size_t>(threads)); };
    // httplib's default also sets SO_REUSEPORT, which lets a second `serve`
    // (with another database!) share the port and receive half the answers.
    // SO_REUSEADDR alone still allows a quick restart after a kill.
    impl_->http.set_socket_options([impl = impl_.get()](socket_t sock) {
        int yes = 1;
        setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
        impl->listenSocket = sock;
    });
    impl_->http.set_payload_max_length(kMaxBody);
    impl_->http.set_keep_alive_timeout(2);  // idle browsers must not hold worker threads
    impl_->http.set_read_timeout(10);
    impl_->routes();
}

StudyServer::~StudyServer() = default;

void StudyServer::run(const std::function<void(int)>& onListening) {
    int port = impl_->options.port;
    if (port == 0) {
        port = impl_->http.bind_to_any_port(impl_->options.host);
        if (port < 0) throw IoError("address", impl_->options.host, "cannot listen on any port");
    } else if (!impl_->http.bind_to_port(impl_->options.host, port)) {
        throw IoError("address", fmt::format("{}:{}", impl_->options.host, port),
                      "cannot listen (port in use, or not a local address?)");
    }
    // Debian's libcpp-httplib listens with a backlog of 5: a burst of observers
    // (a class starting together) would see refused connections. listen() on
    // a listening socket only changes its backlog (Linux).
    if (impl_->listenSocket >= 0) ::listen(impl_->listenSocket, kListenBacklog);
    impl_->boundPort = port;
    if (onListening) onListening(port);
    // httplib's stop() only acts once its accept loop runs (and must be called
    // once), so a stop() that comes early (a Ctrl-C during start-up) is
    // carried out here, as soon as the loop is running.
    std::atomic<bool> done{false};
    std::thread watcher([this, &done] {
        std::unique_lock lock(impl_->stopMutex);
        while (!done) {
            if (impl_->stopRequested && impl_->http.is_running()) {
                impl_->http.stop();
                return;
            }
            impl_->stopCv.wait_for(lock, std::chrono::milliseconds(20));
        }
    });
    impl_->http.listen_after_bind();
    done = true;
    impl_->stopCv.notify_all();
    watcher.join();
}

void StudyServer::stop() {
    std::lock_guard lock(impl_->stopMutex);
    impl_->stopRequested = true;
    impl_->stopCv.notify_all();
}

}  // namespace mucosa::study
