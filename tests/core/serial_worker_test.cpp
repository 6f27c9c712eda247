// SerialWorker: jobs in order on one background thread, a bounded queue, and
// a job's exception back in the caller's thread.
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include <mucosa/core/parallel.hpp>

namespace mucosa {
namespace {

TEST(SerialWorker, RunsEveryJobInOrderOffTheCallersThread) {
    std::vector<int> order;
    std::thread::id worker;
    {
        SerialWorker w(2);
        for (int i = 0; i < 50; ++i)
            w.push([&order, &worker, i] {
                if (i % 7 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
                order.push_back(i);
                worker = std::this_thread::get_id();
            });
        w.finish();
        ASSERT_EQ(order.size(), 50u);
        EXPECT_NE(worker, std::this_thread::get_id());
        w.push([&order] { order.push_back(50); });
    }  // the destructor runs what is queued
    ASSERT_EQ(order.size(), 51u);
    for (int i = 0; i <= 50; ++i) EXPECT_EQ(order[static_cast<std::size_t>(i)], i);
}

TEST(SerialWorker, AtMostCapacityJobsWait) {
    std::atomic<bool> release{false};
    std::atomic<int> pushed{0};
    SerialWorker w(2);
    std::thread producer([&] {
        for (int i = 0; i < 5; ++i) {
            w.push([&release] {
                while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
            });
            ++pushed;
        }
    });
    // One job running (blocked) and two waiting: the fourth push blocks.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (pushed < 3 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_EQ(pushed.load(), 3);
    release = true;
    producer.join();
    w.finish();
    EXPECT_EQ(pushed.load(), 5);
}

TEST(SerialWorker, AJobsExceptionReachesTheCallerAndStopsTheQueue) {
    int ran = 0;
    std::atomic<bool> queued{false};
    SerialWorker w(4);
    w.push([&ran] { ++ran; });
    // The failing job waits until the third job is queued, so the error
    // reaches finish() (a push after the failure would report it instead).
    w.push([&queued] {
        while (!queued) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        throw std::runtime_error("disk full");
    });
    w.push([&ran] { ++ran; });
    queued = true;
    try {
        w.finish();
        ADD_FAILURE() << "finish() did not rethrow";
    } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "disk full");
    }
    EXPECT_EQ(ran, 1);          // the job after the failed one was dropped
    w.push([&ran] { ++ran; });  // reported once: the worker goes on
    w.finish();
    EXPECT_EQ(ran, 2);
}

TEST(SerialWorker, APushAfterAFailedJobReportsIt) {
    SerialWorker w(4);
    w.push([] { throw std::runtime_error("disk full"); });
    // Wait (bounded) until the failure is recorded: the next push reports it.
    bool reported = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!reported && std::chrono::steady_clock::now() < deadline) {
        try {
            w.push([] {});
            w.finish();  // may rethrow if the failure came after this push
        } catch (const std::runtime_error& e) {
            EXPECT_STREQ(e.what(), "disk full");
            reported = true;
        }
    }
    EXPECT_TRUE(reported);
    w.finish();  // reported once
}

}  // namespace
}  // namespace mucosa
