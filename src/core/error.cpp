#include <mucosa/core/error.hpp>

#include <sstream>

namespace mucosa {

namespace {
std::string compose(const std::string& what, const std::string& file, const std::string& why) {
    std::string s = what;
    if (!file.empty()) s += " in " + file;
    if (!why.empty()) s += ": " + why;
    return s;
}

std::string composeAt(const std::string& what, const std::string& file, int line, int column, const std::string& why) {
    std::string s = (file.empty() ? "line " + std::to_string(line) + ", column " + std::to_string(column)
                                  : file + ":" + std::to_string(line) + ":" + std::to_string(column)) +
                    ": " + what;
    if (!why.empty()) s += ": " + why;
    return s;
}
}  // namespace

Error::Error(std::string what, std::string file, std::string why)
    : std::runtime_error(compose(what, file, why)),
      subject_(std::move(what)),
      file_(std::move(file)),
      reason_(std::move(why)) {}

Error::Error(std::string what, std::string file, int line, int column, std::string why)
    : std::runtime_error(composeAt(what, file, line, column, why)),
      subject_(std::move(what)),
      file_(std::move(file)),
      reason_(std::move(why)),
      line_(line),
      column_(column) {}

std::string describe(const Error& e) {
    return e.what();
}

namespace detail {
void checkFailed(const char* expr, const char* file, int line, const std::string& msg) {
    std::ostringstream os;
    os << "internal check failed: " << expr << " at " << file << ":" << line;
    if (!msg.empty()) os << " (" << msg << ")";
    throw InternalError(os.str());
}
}  // namespace detail

}  // namespace mucosa
