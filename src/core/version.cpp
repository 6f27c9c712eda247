#include <mucosa/core/version.hpp>

namespace mucosa {
std::string_view version() noexcept {
    return MUCOSA_VERSION_STRING;
}
}  // namespace mucosa
