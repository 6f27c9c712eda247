#pragma once
// `mucosa study serve`: the web runner. One HTTP server (cpp-httplib) serves
// the embedded page, the plan's images (by index only: no path ever comes from
// a request) and a small JSON API; every answer is committed to SQLite (WAL,
// synchronous=FULL) before the observer sees the next screen.
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include <mucosa/study/plan.hpp>

namespace mucosa::study {

struct ServeOptions {
    std::string host = "127.0.0.1";
    int port = 8080;  // 0 = any free port
    std::filesystem::path db;
    int threads = 0;  // HTTP worker threads; 0 = 64
};

class StudyServer {
public:
    // Opens (or creates) the database and checks it belongs to `plan`.
    StudyServer(Plan plan, ServeOptions options);
    ~StudyServer();
    StudyServer(const StudyServer&) = delete;
    StudyServer& operator=(const StudyServer&) = delete;

    // Binds, calls onListening(port), then serves until stop(). Throws IoError
    // if the address cannot be bound.
    void run(const std::function<void(int port)>& onListening = {});
    void stop();  // thread-safe, at any time (also before run() listens)

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace mucosa::study
