#include <mucosa/core/file.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <string_view>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>

namespace mucosa {

namespace fs = std::filesystem;

namespace {
std::string errnoText(int err) {
    return std::strerror(err);
}

fs::path directoryOf(const fs::path& path) {
    fs::path dir = path.parent_path();
    return dir.empty() ? fs::path(".") : dir;
}
}  // namespace

AtomicFile::AtomicFile(fs::path path) : path_(std::move(path)) {
    if (path_.filename().empty()) throw IoError("output path", path_.string(), "names a directory, not a file");
    const fs::path dir = directoryOf(path_);
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw IoError("output path", path_.string(), "directory '" + dir.string() + "' does not exist");
    if (fs::is_directory(path_, ec)) throw IoError("output path", path_.string(), "is a directory");
    std::string name = ".";
    name += path_.filename().string();
    name += ".tmp-XXXXXX";
    std::string templ = (dir / name).string();
    fd_ = ::mkstemp(templ.data());
    if (fd_ < 0) throw IoError("output path", path_.string(), "cannot create a file there (" + errnoText(errno) + ")");
    ::fchmod(fd_, 0644);
    tmp_ = templ;
}

std::size_t removeStaleTemporaries(const std::vector<fs::path>& paths) {
    // Per folder: the names whose temporaries go.
    std::map<fs::path, std::set<std::string>> byFolder;
    for (const fs::path& p : paths) byFolder[directoryOf(p)].insert(p.filename().string());
    std::size_t removed = 0;
    constexpr std::string_view kTmp = ".tmp-";
    constexpr std::size_t kRandom = 6;  // mkstemp's XXXXXX
    for (const auto& [dir, names] : byFolder) {
        std::error_code ec;
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
            const std::string n = it->path().filename().string();
            if (n.size() < 1 + kTmp.size() + kRandom || n[0] != '.') continue;
            const std::size_t at = n.size() - kRandom - kTmp.size();
            if (n.compare(at, kTmp.size(), kTmp) != 0) continue;
            if (!names.count(n.substr(1, at - 1))) continue;
            std::error_code rm;
            if (fs::remove(it->path(), rm)) ++removed;
        }
    }
    return removed;
}

AtomicFile::~AtomicFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_ && !tmp_.empty()) {
        std::error_code ec;
        fs::remove(tmp_, ec);
    }
}

void AtomicFile::write(const void* data, std::size_t size) {
    MUCOSA_CHECK(fd_ >= 0, "write after commit");
    const auto* p = static_cast<const char*>(data);
    while (size > 0) {
        const ssize_t n = ::write(fd_, p, size);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw IoError("output", path_.string(), "write failed (" + errnoText(errno) + ")");
        }
        p += n;
        size -= static_cast<std::size_t>(n);
    }
}

void AtomicFile::commit() {
    MUCOSA_CHECK(fd_ >= 0, "commit twice");
    if (::fsync(fd_) != 0 && errno != EINVAL)
        throw IoError("output", path_.string(), "fsync failed (" + errnoText(errno) + ")");
    if (::close(fd_) != 0) {
        fd_ = -1;
        throw IoError("output", path_.string(), "close failed (" + errnoText(errno) + ")");
    }
    fd_ = -1;
    if (::rename(tmp_.c_str(), path_.c_str()) != 0)
        throw IoError("output", path_.string(), "rename failed (" + errnoText(errno) + ")");
    committed_ = true;
}

void writeFileAtomic(const fs::path& path, std::span<const std::byte> bytes) {
    AtomicFile f(path);
    f.write(bytes);
    f.commit();
}

void writeFileAtomic(const fs::path& path, const std::string& text) {
    AtomicFile f(path);
    f.write(text);
    f.commit();
}

std::vector<std::byte> readFile(const fs::path& path) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw IoError("input", path.string(), "no such file");
    if (fs::is_directory(path, ec)) throw IoError("input", path.string(), "is a directory");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("input", path.string(), "cannot open (" + errnoText(errno) + ")");
    in.seekg(0, std::ios::end);
    const auto size = in.tellg();
    in.seekg(0, std::ios::beg);
    std::vector<std::byte> bytes(static_cast<std::size_t>(size));
    if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) throw IoError("input", path.string(), "read failed");
    return bytes;
}

std::string readTextFile(const fs::path& path) {
    auto bytes = readFile(path);
    return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

void requireWritable(const fs::path& path) {
    AtomicFile probe(path);  // creates and removes a temporary next to the target
}

std::uint64_t availableDiskBytes(const fs::path& path) {
    fs::path probe = path.empty() ? fs::path(".") : path;
    std::error_code ec;
    while (!fs::exists(probe, ec) && probe.has_parent_path() && probe.parent_path() != probe)
        probe = probe.parent_path();
    if (!fs::exists(probe, ec)) probe = probe.is_absolute() ? probe.root_path() : fs::path(".");  // "fly.png": here
    struct statvfs st {};
    if (::statvfs(probe.c_str(), &st) != 0) throw IoError("disk", path.string(), std::strerror(errno));
    return static_cast<std::uint64_t>(st.f_bavail) * static_cast<std::uint64_t>(st.f_frsize);
}

void requireDisk(std::uint64_t bytes, const fs::path& path, const std::string& what) {
    const std::uint64_t free = availableDiskBytes(path);
    if (bytes > free)
        throw ResourceError(what, path.string(),
                            fmt::format("needs {} of disk but only {} are free on its file system", formatBytes(bytes),
                                        formatBytes(free)));
}

bool resolvesInside(const std::filesystem::path& folder, const std::filesystem::path& target) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path base = fs::weakly_canonical(folder.empty() ? fs::path(".") : folder, ec);
    if (ec) return false;
    const fs::path resolved = fs::weakly_canonical(target, ec);
    if (ec) return false;
    auto b = base.begin(), t = resolved.begin();
    for (; b != base.end(); ++b, ++t) {
        if (b->empty()) break;  // a trailing separator: the last element
        if (t == resolved.end() || *b != *t) return false;
    }
    return true;
}

std::optional<std::filesystem::path> confinedPath(const std::filesystem::path& folder, const std::string& reference) {
    if (reference.empty() || reference.find('\0') != std::string::npos) return std::nullopt;
    // A scheme ("file:", "http:") or a drive letter ("C:") is never local-relative.
    const auto colon = reference.find(':');
    if (colon != std::string::npos && reference.find('/') > colon) return std::nullopt;
    if (reference.front() == '/' || reference.front() == '\\') return std::nullopt;
    const std::filesystem::path joined = (folder.empty() ? std::filesystem::path(".") : folder) / reference;
    if (!resolvesInside(folder, joined)) return std::nullopt;
    return folder.empty() ? std::filesystem::path(reference) : folder / reference;
}

}  // namespace mucosa
