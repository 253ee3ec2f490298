# logram as a user C module of a CMake-built port (rp2: the Pico 2 build).
add_library(usermod_logram INTERFACE)
target_sources(usermod_logram INTERFACE ${CMAKE_CURRENT_LIST_DIR}/modlogram.c)
target_include_directories(usermod_logram INTERFACE ${CMAKE_CURRENT_LIST_DIR})
target_link_libraries(usermod INTERFACE usermod_logram)
