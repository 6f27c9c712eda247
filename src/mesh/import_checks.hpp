#pragma once
// Checks that run in the calling process before a file is handed to Assimp
// (which runs isolated, see core/isolate.hpp): a lying header is refused with
// a clear message instead of costing the parser its memory limit, and no file
// outside the model's folder is ever read on the file's say-so.
#include <cstdint>
#include <filesystem>
#include <string>

namespace mucosa::mesh::detail {

// True when `reference` (a URI or path written in the file) names a file inside
// `folder` (or the folder itself's tree): relative, no scheme, no escape by
// "..", after symlinks are resolved. Percent-escapes are decoded first.
bool insideFolder(const std::filesystem::path& folder, const std::string& reference);

// A URI reference's percent-escapes decoded (RFC 3986 2.1); a '%' not followed
// by two hex digits is kept as it is.
std::string percentDecoded(const std::string& s);

// PLY element counts and binary STL's triangle count against the file's size;
// a PLY header must end (end_header) within 1 MiB / 10000 lines.
void checkDeclaredSizes(const std::filesystem::path& path, const std::string& ext, std::uintmax_t fileBytes);

// glTF 2.0 (.gltf JSON or .glb): GLB chunk lengths within the file; every
// buffer and image URI a data: URI or a file inside the model's folder;
// buffers no longer than what backs them (the GLB BIN chunk, the decoded data
// URI, the file); buffer views inside their buffers; accessors inside their
// views; accessors without data (zero-filled) bounded.
void checkGltf(const std::filesystem::path& path, bool binary, std::uintmax_t fileBytes);

}  // namespace mucosa::mesh::detail
