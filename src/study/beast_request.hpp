#pragma once
// A request parsed by Boost.Beast, as the transport-independent HttpRequest
// (server.cpp and fuzz/fuzz_study_http.cpp): one conversion for both.
#include <string>
#include <utility>

#include <boost/beast/http.hpp>

#include "http_handler.hpp"

namespace mucosa::study::detail {

// A parser with the server's limits: headers 8 KiB, body 16 KiB, chunked or not.
inline void limitParser(boost::beast::http::request_parser<boost::beast::http::string_body>& parser) {
    parser.header_limit(static_cast<std::uint32_t>(kHeaderLimit));
    parser.body_limit(kBodyLimit);
}

inline HttpRequest fromBeast(boost::beast::http::request<boost::beast::http::string_body>&& req, std::string peer) {
    HttpRequest r;
    r.method = std::string(req.method_string());
    r.target = std::string(req.target());
    for (const auto& f : req) r.headers.emplace_back(std::string(f.name_string()), std::string(f.value()));
    r.body = std::move(req.body());
    r.peer = std::move(peer);
    return r;
}

}  // namespace mucosa::study::detail
