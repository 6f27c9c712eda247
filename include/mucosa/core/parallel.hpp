#pragma once
// Thread counts: 0 means "all hardware threads"; requests above the hardware
// are capped (results never depend on the count, see each algorithm).
namespace mucosa {
int resolveThreads(int requested) noexcept;
}  // namespace mucosa
