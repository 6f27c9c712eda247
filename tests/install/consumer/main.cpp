// A user's program built against an installed Mucosa.
#include <cstdio>
#include <string>

#include <mucosa/core/version.hpp>
#include <mucosa/noise/perlin.hpp>

int main() {
    std::printf("mucosa %s\n", std::string(mucosa::version()).c_str());
    std::printf("perlin(3.14, 42, 7) = %.17g\n", mucosa::noise::perlin(3.14, 42, 7));
    return mucosa::noise::perlin(3.14, 42, 7) == 0.13691995878400012 ? 0 : 1;
}
