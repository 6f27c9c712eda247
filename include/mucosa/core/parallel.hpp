#pragma once
// Thread counts: 0 means "all hardware threads"; requests above the hardware
// are capped (results never depend on the count, see each algorithm).
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace mucosa {
int resolveThreads(int requested) noexcept;

// One background thread that runs jobs in the order they were queued: the
// encoding and writing of a frame's files while the caller renders the next
// (mucosa render). At most `capacity` jobs wait; push() blocks beyond that,
// so memory stays flat however many frames there are. The first job that
// throws stops the queue: the jobs after it are dropped, and push() and
// finish() rethrow its exception in the caller's thread. The destructor
// runs what is queued (or drops it after an error) and joins.
class SerialWorker {
public:
    explicit SerialWorker(std::size_t capacity = 2);
    ~SerialWorker();
    SerialWorker(const SerialWorker&) = delete;
    SerialWorker& operator=(const SerialWorker&) = delete;

    void push(std::function<void()> job);
    // Waits until every queued job has run; rethrows a job's exception.
    void finish();

private:
    void run();
    void rethrow();

    std::size_t capacity_;
    std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<std::function<void()>> jobs_;
    bool busy_ = false, stopping_ = false;
    std::exception_ptr error_;
    std::thread thread_;
};

}  // namespace mucosa
