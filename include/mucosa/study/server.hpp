#pragma once
// `mucosa study serve`: the web runner. One HTTP server (Boost.Beast, async on
// a few threads) serves the embedded page, the plan's images (by index only:
// no path ever comes from a request) and a small JSON API; every answer is
// committed to SQLite (WAL, synchronous=FULL) before the observer sees the
// next screen. Each observer slot has a secret link (a 128-bit token, made
// once per study and kept in the database); without a valid token no route
// reads or writes study data. Requests are bounded (docs/hardening/study-server.md).
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <mucosa/study/plan.hpp>

namespace mucosa::study {

struct ServeOptions {
    std::string host = "127.0.0.1";
    int port = 8080;  // 0 = any free port
    std::filesystem::path db;
    int threads = 0;                // request workers (they wait on SQLite commits); 0 = 8
    int maxConnections = 512;       // open connections in total; more are closed at once
    int maxClientConnections = 64;  // ... from one client address (~10 browsers behind one NAT; raise for more)
};

class StudyServer {
public:
    // Opens (or creates) the database, checks it belongs to `plan`, and makes
    // the observer slots' tokens the first time.
    StudyServer(Plan plan, ServeOptions options);
    ~StudyServer();
    StudyServer(const StudyServer&) = delete;
    StudyServer& operator=(const StudyServer&) = delete;

    // Binds, calls onListening(port), then serves until stop(). Throws IoError
    // if the address cannot be bound.
    void run(const std::function<void(int port)>& onListening = {});
    void stop();  // thread-safe, at any time (also before run() listens)

    // Each slot's secret link, in slot order: http://HOST:PORT/?t=TOKEN.
    std::vector<std::string> observerLinks(int port) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Writes one link per line, mode 0600, under a temporary name then renamed
// (the file holds secrets). Throws IoError.
void writeLinksFile(const std::filesystem::path& path, const std::vector<std::string>& links);

}  // namespace mucosa::study
