# Every .cpp in apps/mucosa is part of the tool; subcommands register
# themselves (MUCOSA_REGISTER_COMMAND in commands.hpp).
file(GLOB mucosa_cli_sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/*.cpp)
target_sources(mucosa_cli PRIVATE ${mucosa_cli_sources})
