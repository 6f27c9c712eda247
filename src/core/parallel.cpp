#include <mucosa/core/parallel.hpp>

#include <algorithm>
#include <thread>

namespace mucosa {

int resolveThreads(int requested) noexcept {
    const int hw = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    return requested <= 0 ? hw : std::min(requested, hw);
}

SerialWorker::SerialWorker(std::size_t capacity) : capacity_(std::max<std::size_t>(1, capacity)) {
    thread_ = std::thread([this] { run(); });
}

SerialWorker::~SerialWorker() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    changed_.notify_all();
    thread_.join();
}

void SerialWorker::rethrow() {
    if (error_) {
        std::exception_ptr e = error_;
        error_ = nullptr;  // reported once; the queue stays stopped (jobs_ is emptied)
        std::rethrow_exception(e);
    }
}

void SerialWorker::push(std::function<void()> job) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return jobs_.size() < capacity_ || error_; });
    rethrow();
    jobs_.push_back(std::move(job));
    lock.unlock();
    changed_.notify_all();
}

void SerialWorker::finish() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return (jobs_.empty() && !busy_) || error_; });
    rethrow();
}

void SerialWorker::run() {
    std::unique_lock lock(mutex_);
    for (;;) {
        changed_.wait(lock, [&] { return !jobs_.empty() || stopping_; });
        if (jobs_.empty()) return;  // stopping, nothing left
        std::function<void()> job = std::move(jobs_.front());
        jobs_.pop_front();
        busy_ = true;
        lock.unlock();
        changed_.notify_all();  // a place in the queue is free
        std::exception_ptr failed;
        try {
            job();
        } catch (...) {
            failed = std::current_exception();
        }
        lock.lock();
        busy_ = false;
        if (failed) {
            error_ = failed;
            jobs_.clear();
        }
        changed_.notify_all();
    }
}

}  // namespace mucosa
