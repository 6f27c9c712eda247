#include <mucosa/core/parallel.hpp>

#include <algorithm>
#include <thread>

namespace mucosa {
int resolveThreads(int requested) noexcept {
    const int hw = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    return requested <= 0 ? hw : std::min(requested, hw);
}
}  // namespace mucosa
