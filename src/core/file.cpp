#include <mucosa/core/file.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>

#include <mucosa/core/error.hpp>

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

}  // namespace mucosa
