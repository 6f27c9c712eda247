// The study server's request handling (src/study/http_handler.cpp) without
// sockets: arbitrary bytes are parsed by Boost.Beast with the server's limits,
// and every complete request goes to the handler, which must answer every one
// (a status, never an exception) against a small in-memory plan and a real
// answers database. Slot 0's token is 32 '0's, slot 1's 32 '1's (the seeds use
// them), so the authenticated routes are reached too.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <boost/asio/buffer.hpp>
#include <boost/beast/http.hpp>

#include <mucosa/study/plan.hpp>

#include "beast_request.hpp"
#include "fuzz_support.hpp"
#include "http_handler.hpp"
#include "store.hpp"

namespace {

namespace study = mucosa::study;

struct Fixture {
    study::Plan plan;
    std::unique_ptr<study::detail::AnswerStore> store;
    std::unique_ptr<study::detail::HttpHandler> handler;

    Fixture() {
        const auto dir = mucosa::fuzz::scratchDir();
        for (int i = 0; i < 3; ++i) {
            study::Image im;
            im.id = "I" + std::to_string(i);
            im.file = dir / ("img" + std::to_string(i) + ".png");
            im.category = i == 0 ? 1 : 5 - i % 2;
            im.patient = "p";
            im.pose = std::to_string(i);
            std::ofstream(im.file, std::ios::binary) << "\x89PNG fuzz image " << i;
            plan.images.push_back(im);
        }
        plan.options.observers = 2;
        plan.options.seriesLength = 2;
        using K = study::TrialKind;
        study::ObserverPlan op;
        op.trials = {{K::Calibration, -1, 0, 2}, {K::Likert, 1, -1, -1}, {K::Likert, 2, -1, -1}, {K::TwoAfc, -1, 1, 2}};
        plan.observers = {op, op};
        plan.fingerprint = "fuzz";
        store = std::make_unique<study::detail::AnswerStore>(dir / "answers.sqlite", plan.fingerprint);
        handler = std::make_unique<study::detail::HttpHandler>(
            plan, *store, std::vector<std::string>{std::string(32, '0'), std::string(32, '1')}, "127.0.0.1");
        handler->setPort(8080);
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static Fixture fixture;
    namespace http = boost::beast::http;
    return mucosa::fuzz::guarded([&] {
        const char* p = reinterpret_cast<const char*>(data);
        std::size_t left = size;
        // Several requests may follow one another, as on a keep-alive connection.
        for (int n = 0; n < 8 && left > 0; ++n) {
            http::request_parser<http::string_body> parser;
            mucosa::study::detail::limitParser(parser);
            parser.eager(true);
            boost::beast::error_code ec;
            const std::size_t used = parser.put(boost::asio::buffer(p, left), ec);
            if (ec == http::error::need_more && !parser.is_done()) parser.put_eof(ec);
            if (ec || !parser.is_done() || used == 0) return;
            const auto res = fixture.handler->handle(mucosa::study::detail::fromBeast(parser.release(), "127.0.0.1"));
            if (res.status < 200 || res.status > 599 || res.contentType.empty()) {
                std::fprintf(stderr, "fuzz: handler answered status %d, content type '%s'\n", res.status,
                             res.contentType.c_str());
                std::abort();
            }
            static const bool verbose = std::getenv("FUZZ_STUDY_HTTP_VERBOSE") != nullptr;  // seed triage
            if (verbose) std::fprintf(stderr, "%d %s\n", res.status, res.body.substr(0, 120).c_str());
            p += used;
            left -= used;
        }
    });
}
