#pragma once
// Two tiers of failure (STYLE.md, "Errors"):
//  - bad user input (files, parameters, scene JSON, CSV) throws a typed
//    mucosa::Error carrying the file and, where it applies, the field or line;
//    apps/ catch it once and print `error: <what> in <file>: <why>`;
//  - broken internal invariants trip MUCOSA_CHECK (always on) or MUCOSA_DCHECK
//    (debug only), which throw mucosa::InternalError.
#include <stdexcept>
#include <string>

namespace mucosa {

class Error : public std::runtime_error {
public:
    // what: the thing that is wrong ("size", "frequency", "PNG header");
    // file: the file it concerns (may be empty); why: the reason.
    Error(std::string what, std::string file, std::string why);
    // At a place in a text file (1-based line and column, as editors count):
    // "<file>:<line>:<column>: <what>: <why>", the form compilers print
    // ("line <line>, column <column>: ..." without a file).
    Error(std::string what, std::string file, int line, int column, std::string why);

    const std::string& subject() const noexcept { return subject_; }
    const std::string& file() const noexcept { return file_; }
    const std::string& reason() const noexcept { return reason_; }
    int line() const noexcept { return line_; }  // 0: no position
    int column() const noexcept { return column_; }

private:
    std::string subject_, file_, reason_;
    int line_ = 0, column_ = 0;
};

// Input that cannot be used: a parameter out of range, a malformed file.
class InputError : public Error {
public:
    using Error::Error;
};

// The operating system refused: unreadable or unwritable path, disk full.
class IoError : public Error {
public:
    using Error::Error;
};

// A request that would exhaust a resource (memory) and was refused up front.
class ResourceError : public Error {
public:
    using Error::Error;
};

class InternalError : public std::logic_error {
public:
    using std::logic_error::logic_error;
};

// Formats the one-line message apps print: "<what> in <file>: <why>", or
// "<what>: <why>" when no file is involved, or "<file>:<line>:<column>: <what>:
// <why>" at a place in a file.
std::string describe(const Error& e);

namespace detail {
[[noreturn]] void checkFailed(const char* expr, const char* file, int line, const std::string& msg);
}  // namespace detail

}  // namespace mucosa

#define MUCOSA_CHECK(cond, msg)                                                       \
    do {                                                                              \
        if (!(cond)) ::mucosa::detail::checkFailed(#cond, __FILE__, __LINE__, (msg)); \
    } while (false)

#ifndef NDEBUG
#define MUCOSA_DCHECK(cond, msg) MUCOSA_CHECK(cond, msg)
#else
#define MUCOSA_DCHECK(cond, msg) \
    do {                         \
    } while (false)
#endif
