#pragma once
// Atomic file output: every output is written to a temporary name in the
// destination directory and renamed over the final name only when complete, so
// a crash, a full disk or an error never leaves a half-written file behind.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace mucosa {

class AtomicFile {
public:
    // Creates `<dir>/.<name>.tmp-XXXXXX` next to `path`; throws IoError if the
    // directory is missing or unwritable.
    explicit AtomicFile(std::filesystem::path path);
    ~AtomicFile();  // removes the temporary unless commit() succeeded
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    void write(const void* data, std::size_t size);
    void write(std::span<const std::byte> bytes) { write(bytes.data(), bytes.size()); }
    void write(const std::string& text) { write(text.data(), text.size()); }

    // Flushes, fsyncs and renames onto the final path.
    void commit();

    const std::filesystem::path& path() const noexcept { return path_; }
    const std::filesystem::path& temporaryPath() const noexcept { return tmp_; }

private:
    std::filesystem::path path_, tmp_;
    int fd_ = -1;
    bool committed_ = false;
};

// Removes the temporaries AtomicFile left beside any of `paths`
// (`.<name>.tmp-XXXXXX`: a process killed mid-write, which no destructor
// cleaned up). Only for paths no running process is writing, e.g. the frames
// a resumed run is about to render again. Returns how many it removed.
std::size_t removeStaleTemporaries(const std::vector<std::filesystem::path>& paths);

// Writes a whole buffer atomically.
void writeFileAtomic(const std::filesystem::path& path, std::span<const std::byte> bytes);
void writeFileAtomic(const std::filesystem::path& path, const std::string& text);

// Reads a whole file; throws IoError naming the file if it cannot.
std::vector<std::byte> readFile(const std::filesystem::path& path);
std::string readTextFile(const std::filesystem::path& path);

// Fails early (before any work) if `path` could not be created: its directory
// is missing or not writable. Throws IoError.
void requireWritable(const std::filesystem::path& path);

// Bytes an unprivileged writer may still use on the file system holding
// `path` (or its parent folder when it does not exist yet): statvfs f_bavail.
std::uint64_t availableDiskBytes(const std::filesystem::path& path);

// Throws ResourceError("<what>", path, "needs N (X GiB) but only M are free
// on its file system") when `bytes` will not fit: checked before a long run
// starts writing, so it is refused instead of failing half way.
void requireDisk(std::uint64_t bytes, const std::filesystem::path& path, const std::string& what);

// True when `target` resolves (symlinks followed, ".." applied) to `folder` or
// a path below it.
bool resolvesInside(const std::filesystem::path& folder, const std::filesystem::path& target);

// For a path a file names (a sidecar's outputs, a glTF buffer URI, a frames
// list's image): the path joined to `folder` if `reference` is relative, has
// no scheme or drive ("file:", "C:"), and stays inside `folder`; otherwise
// nothing. The one rule for "a file may only name files beside it".
std::optional<std::filesystem::path> confinedPath(const std::filesystem::path& folder, const std::string& reference);

}  // namespace mucosa
