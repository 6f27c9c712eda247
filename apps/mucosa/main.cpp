// mucosa: the command-line tool. Library errors are caught here, once, and
// printed as one `error: ...` line (STYLE.md, "Errors").
#include <cstdio>
#include <exception>
#include <new>

#include <CLI/CLI.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/version.hpp>

#include "commands.hpp"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
// Sanitizer builds: the tool loads Mesa's driver, after which LeakSanitizer's
// exit-time scan of dynamic TLS (recorded by its __tls_get_addr interceptor)
// can meet a garbage record and crash ("Tracer caught signal 11"). The tests
// run it from scripts too, outside ctest's per-test environment, so the
// default lives in the binary (ASAN_OPTIONS still overrides it); see
// tests/CMakeLists.txt. LSan still scans each thread's static TLS.
extern "C" const char* __asan_default_options() {
    return "intercept_tls_get_addr=0";
}
#endif
#endif

int main(int argc, char** argv) {
    using namespace mucosa;
    // Line-buffered even into a file or pipe, so a run that is killed keeps
    // every line of its log.
    std::setvbuf(stdout, nullptr, _IOLBF, BUFSIZ);
    CLI::App app{"Mucosa: photorealistic real-time rendering of wet, mucus-covered tissue.", "mucosa"};
    app.set_version_flag("--version", std::string(version()));
    app.require_subcommand(1);
    app.fallthrough();
    cli::Global global;
    app.add_option("--threads", global.threads, "Worker threads (0 = all cores)")->check(cli::wholeNumber(0));
    app.add_flag("-q,--quiet", global.quiet, "Print only warnings and errors");
    cli::addRegisteredCommands(app, global);
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "error: %s\n", cli::describeParseError(app, e).c_str());
        return 2;
    } catch (const Error& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "error: out of memory\n");
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
