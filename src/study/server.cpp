#include <mucosa/study/server.hpp>

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include <mucosa/core/error.hpp>

#include "beast_request.hpp"
#include "http_handler.hpp"
#include "store.hpp"

namespace mucosa::study {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using namespace std::chrono_literals;

namespace {

constexpr int kListenBacklog = 1024;            // pending connections (clamped to somaxconn)
constexpr int kIoThreads = 2;                   // run the sockets (async: a slow client costs no thread)
constexpr int kDefaultWorkers = 8;              // run the handler (SQLite commits block)
constexpr auto kRequestDeadline = 10s;          // a whole request, headers and body, from its first byte
constexpr auto kIdleTimeout = 5s;               // a keep-alive connection waiting for its next request
constexpr auto kWriteDeadline = 30s;            // a whole response
constexpr auto kDrainDeadline = 2s;             // reading what a refused request still sends, before closing
constexpr std::size_t kDrainBytes = 1u << 20;   // ... at most this much
constexpr std::size_t kReadBuffer = 64 * 1024;  // bounds a chunk header line too

// Open connections, in total and per client address; a connection past
// either limit is closed at once.
class ConnectionLimits {
public:
    ConnectionLimits(int total, int perClient) : maxTotal_(total), maxPerClient_(perClient) {}
    bool acquire(const std::string& peer) {
        std::lock_guard lock(mutex_);
        int& n = perPeer_[peer];
        if (total_ >= maxTotal_ || n >= maxPerClient_) {
            if (n == 0) perPeer_.erase(peer);
            return false;
        }
        ++n;
        ++total_;
        return true;
    }
    void release(const std::string& peer) {
        std::lock_guard lock(mutex_);
        if (--perPeer_[peer] <= 0) perPeer_.erase(peer);
        --total_;
    }

private:
    std::mutex mutex_;
    std::unordered_map<std::string, int> perPeer_;
    int total_ = 0;
    const int maxTotal_, maxPerClient_;
};

// One client connection: read a request within its deadline, have a worker
// answer it, write the answer, repeat while keep-alive.
class Connection : public std::enable_shared_from_this<Connection> {
public:
    Connection(tcp::socket socket, std::string peer, ConnectionLimits& limits, detail::HttpHandler& handler,
               asio::thread_pool& workers)
        : stream_(std::move(socket)),
          buffer_(kReadBuffer),
          peer_(std::move(peer)),
          limits_(limits),
          handler_(handler),
          workers_(workers) {}
    ~Connection() { limits_.release(peer_); }

    void start() { waitForRequest(); }

private:
    // Idle until the next request's first byte (kIdleTimeout), then the whole
    // request within kRequestDeadline: a client sending a byte a second is
    // cut off at the deadline, however it paces them.
    void waitForRequest() {
        if (buffer_.size() > 0) return readRequest();  // pipelined: already here
        stream_.expires_after(kIdleTimeout);
        stream_.async_read_some(buffer_.prepare(1024),
                                [self = shared_from_this()](beast::error_code ec, std::size_t n) {
                                    if (ec) return self->close();
                                    self->buffer_.commit(n);
                                    self->readRequest();
                                });
    }

    void readRequest() {
        parser_.emplace();
        detail::limitParser(*parser_);  // chunked bodies too: counted as they arrive
        stream_.expires_after(kRequestDeadline);
        http::async_read(stream_, buffer_, *parser_,
                         [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRead(ec); });
    }

    void onRead(beast::error_code ec) {
        if (ec == http::error::body_limit) return refuse(413, "request too large");
        if (ec == http::error::header_limit) return refuse(431, "request header too large");
        if (ec == beast::error::timeout || ec == http::error::end_of_stream || ec == asio::error::eof ||
            ec == asio::error::connection_reset || ec == asio::error::operation_aborted)
            return close();
        if (ec) return refuse(400, "malformed HTTP request");
        stream_.expires_never();  // while a worker answers
        version_ = parser_->get().version();
        keepAlive_ = parser_->get().keep_alive();
        detail::HttpRequest r = detail::fromBeast(parser_->release(), peer_);
        asio::post(workers_, [self = shared_from_this(), r = std::move(r)] {
            detail::HttpResponse res = self->handler_.handle(r);
            asio::post(self->stream_.get_executor(),
                       [self, res = std::move(res)]() mutable { self->write(std::move(res), self->keepAlive_); });
        });
    }

    void refuse(int status, const std::string& message) {
        detail::HttpResponse res;
        res.status = status;
        res.contentType = "application/json";
        res.body = fmt::format("{{\"error\":\"{}\"}}", message);
        version_ = 11;
        write(std::move(res), false);
    }

    void write(detail::HttpResponse r, bool keepAlive) {
        res_ = {};
        res_.version(version_);
        res_.result(static_cast<unsigned>(r.status));
        res_.set(http::field::content_type, r.contentType);
        for (const auto& [k, v] : r.headers) res_.set(k, v);
        res_.body() = std::move(r.body);
        res_.keep_alive(keepAlive);
        res_.prepare_payload();
        stream_.expires_after(kWriteDeadline);
        http::async_write(stream_, res_, [self = shared_from_this(), keepAlive](beast::error_code ec, std::size_t) {
            if (ec) return self->close();
            if (keepAlive) return self->waitForRequest();
            self->drainAndClose();
        });
    }

    // A refused request may still be sending its body; closing with unread
    // data would reset the connection before the client reads the answer. So
    // stop sending, read and discard a bounded amount, then close.
    void drainAndClose() {
        beast::error_code ec;
        stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
        drainDeadline_ = std::chrono::steady_clock::now() + kDrainDeadline;
        drain();
    }

    void drain() {
        if (drained_ >= kDrainBytes || std::chrono::steady_clock::now() >= drainDeadline_) return close();
        stream_.expires_at(drainDeadline_);
        buffer_.clear();
        stream_.async_read_some(buffer_.prepare(16 * 1024),
                                [self = shared_from_this()](beast::error_code ec, std::size_t n) {
                                    if (ec) return self->close();
                                    self->drained_ += n;
                                    self->drain();
                                });
    }

    void close() {
        beast::error_code ec;
        stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
        stream_.close();
    }

    beast::tcp_stream stream_;
    beast::flat_buffer buffer_;
    std::optional<http::request_parser<http::string_body>> parser_;
    http::response<http::string_body> res_;
    unsigned version_ = 11;
    bool keepAlive_ = false;
    std::size_t drained_ = 0;
    std::chrono::steady_clock::time_point drainDeadline_;
    std::string peer_;
    ConnectionLimits& limits_;
    detail::HttpHandler& handler_;
    asio::thread_pool& workers_;
};

}  // namespace

struct StudyServer::Impl {
    Plan plan;
    ServeOptions options;
    detail::AnswerStore store;
    std::vector<std::string> tokens;
    detail::HttpHandler handler;
    ConnectionLimits limits{options.maxConnections, options.maxClientConnections};
    asio::io_context ioc{kIoThreads};  // after `limits`: connections release into it when destroyed
    std::optional<tcp::acceptor> acceptor;
    int boundPort = 0;

    Impl(Plan p, ServeOptions o)
        : plan(std::move(p)),
          options(std::move(o)),
          store(options.db, plan.fingerprint),
          tokens(store.slotTokens(static_cast<int>(plan.observers.size()))),
          handler(plan, store, tokens, options.host) {}

    void accept(asio::thread_pool& workers) {
        acceptor->async_accept(asio::make_strand(ioc), [this, &workers](beast::error_code ec, tcp::socket socket) {
            if (ec == asio::error::operation_aborted || !acceptor->is_open()) return;
            if (!ec) {
                beast::error_code e;
                const auto remote = socket.remote_endpoint(e);
                const std::string peer = e ? std::string("?") : remote.address().to_string();
                if (!e && limits.acquire(peer)) {
                    std::make_shared<Connection>(std::move(socket), peer, limits, handler, workers)->start();
                } else {
                    socket.close(e);  // over a limit: closed at once, costs nothing more
                }
            }
            accept(workers);
        });
    }
};

StudyServer::StudyServer(Plan plan, ServeOptions options) {
    if (options.db.empty()) throw InputError("database", "", "give --db answers.sqlite");
    if (options.port < 0 || options.port > 65535) throw InputError("port", "", "must be 0..65535");
    if (options.maxConnections < 1 || options.maxClientConnections < 1)
        throw InputError("connection limits", "", "must be at least 1");
    impl_ = std::make_unique<Impl>(std::move(plan), std::move(options));
}

StudyServer::~StudyServer() = default;

std::vector<std::string> StudyServer::observerLinks(int port) const {
    std::vector<std::string> links;
    std::string host = impl_->options.host;
    if (host.find(':') != std::string::npos) host = "[" + host + "]";  // IPv6 literal
    for (const std::string& t : impl_->tokens) links.push_back(fmt::format("http://{}:{}/?t={}", host, port, t));
    return links;
}

void writeLinksFile(const std::filesystem::path& path, const std::vector<std::string>& links) {
    // Secrets: created 0600 under a temporary name, fsynced, renamed.
    std::filesystem::path dir = path.parent_path();
    if (dir.empty()) dir = ".";
    std::string tmpl = (dir / ("." + path.filename().string() + ".tmp-XXXXXX")).string();
    const int fd = ::mkstemp(tmpl.data());  // mode 0600
    if (fd < 0) throw IoError("links file", path.string(), "cannot create a file there");
    std::string text;
    for (const std::string& l : links) text += l + "\n";
    bool ok = ::fchmod(fd, 0600) == 0;
    for (std::size_t done = 0; ok && done < text.size();) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        ok = n > 0;
        done += ok ? static_cast<std::size_t>(n) : 0;
    }
    ok = ok && ::fsync(fd) == 0;
    ok = ::close(fd) == 0 && ok;
    if (!ok || ::rename(tmpl.c_str(), path.c_str()) != 0) {
        ::unlink(tmpl.c_str());
        throw IoError("links file", path.string(), "cannot write it");
    }
}

void StudyServer::run(const std::function<void(int)>& onListening) {
    Impl& s = *impl_;
    const std::string where = fmt::format("{}:{}", s.options.host, s.options.port);
    beast::error_code ec;
    asio::ip::address address =
        asio::ip::make_address(s.options.host == "localhost" ? "127.0.0.1" : s.options.host, ec);
    if (ec) throw IoError("address", s.options.host, "not an IP address (give e.g. 127.0.0.1 or 0.0.0.0)");
    tcp::acceptor acceptor(s.ioc);
    const tcp::endpoint endpoint(address, static_cast<unsigned short>(s.options.port));
    // SO_REUSEADDR allows a quick restart after a kill; never SO_REUSEPORT,
    // which would let a second `serve` (with another database!) share the
    // port and receive half the answers.
    acceptor.open(endpoint.protocol(), ec);
    if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor.bind(endpoint, ec);
    if (!ec) acceptor.listen(kListenBacklog, ec);
    if (ec)
        throw IoError(
            "address", where,
            s.options.port == 0 ? "cannot listen on any port" : "cannot listen (port in use, or not a local address?)");
    s.boundPort = acceptor.local_endpoint().port();
    s.handler.setPort(s.boundPort);
    s.acceptor.emplace(std::move(acceptor));
    if (onListening) onListening(s.boundPort);

    asio::thread_pool workers(static_cast<std::size_t>(s.options.threads > 0 ? s.options.threads : kDefaultWorkers));
    s.accept(workers);
    std::vector<std::thread> io;
    for (int i = 1; i < kIoThreads; ++i) io.emplace_back([&s] { s.ioc.run(); });
    s.ioc.run();  // returns at stop(), also if stop() came before it
    for (auto& t : io) t.join();
    workers.join();  // an answer being committed is finished, never cut
    s.acceptor.reset();
}

void StudyServer::stop() {
    impl_->ioc.stop();
}

}  // namespace mucosa::study
