# savme's CMake package (installed by crates/capi/scripts/install as
# PREFIX/lib/cmake/savme/savmeConfig.cmake). find_package(savme) defines:
#   savme::savme         the shared library libsavme.so and the headers savme.h, savme.hpp
#   savme::savme_static  the static library libsavme.a (with the system libraries it needs)
# Relocatable: paths are found from this file's place in the prefix.
get_filename_component(_savme_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
if(NOT TARGET savme::savme)
  add_library(savme::savme SHARED IMPORTED)
  set_target_properties(savme::savme PROPERTIES
    IMPORTED_LOCATION "${_savme_prefix}/lib/libsavme.so"
    IMPORTED_SONAME "libsavme.so"
    INTERFACE_INCLUDE_DIRECTORIES "${_savme_prefix}/include")
endif()
if(NOT TARGET savme::savme_static)
  add_library(savme::savme_static STATIC IMPORTED)
  find_package(Threads REQUIRED)
  set_target_properties(savme::savme_static PROPERTIES
    IMPORTED_LOCATION "${_savme_prefix}/lib/libsavme.a"
    INTERFACE_INCLUDE_DIRECTORIES "${_savme_prefix}/include"
    INTERFACE_LINK_LIBRARIES "Threads::Threads;${CMAKE_DL_LIBS};m")
endif()
set(savme_FOUND TRUE)
unset(_savme_prefix)
