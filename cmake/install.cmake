# What `cmake --install BUILD --prefix P` puts under P besides the tools (bin/vdbscatter and
# bin/vdbscatter-view, installed by the root CMakeLists.txt): the shared library and the static
# archives, the public headers, a pkg-config file, a CMake package, the Python package and man
# pages made from every command's --help (docs/install.md). Included at the end of the root
# CMakeLists.txt; every path is relative to the prefix, so one build installs anywhere.
include(CMakePackageConfigHelpers)

set(VDBS_INSTALL_LIBDIR lib)
set(VDBS_INSTALL_INCLUDEDIR include)
set(VDBS_INSTALL_CMAKEDIR ${VDBS_INSTALL_LIBDIR}/cmake/vdbscatter)
set(VDBS_INSTALL_MANDIR share/man)

# --- libraries -----------------------------------------------------------------------------
# The shared library with its SONAME link and namelink, and each static archive that a static
# link needs (the library's own, and the lower layers' while they are archives of their own).
set(VDBS_STATIC_TARGETS)
foreach(t vdbscatter vdbscatter_vdbio vdbscatter_status)
  if(TARGET ${t})
    get_target_property(type ${t} TYPE)
    if(type STREQUAL "STATIC_LIBRARY")
      list(APPEND VDBS_STATIC_TARGETS ${t})
    endif()
  endif()
endforeach()
install(TARGETS vdbscatter_shared LIBRARY DESTINATION ${VDBS_INSTALL_LIBDIR})
install(TARGETS ${VDBS_STATIC_TARGETS} ARCHIVE DESTINATION ${VDBS_INSTALL_LIBDIR})

# A tool linked to the shared library finds it beside itself once installed.
foreach(t vdbscatter_cli vdbscatter_view)
  get_target_property(libs ${t} LINK_LIBRARIES)
  if("vdbscatter_shared" IN_LIST libs)
    set_target_properties(${t} PROPERTIES INSTALL_RPATH "$ORIGIN/../${VDBS_INSTALL_LIBDIR}")
  endif()
endforeach()

# --- public headers: vdbscatter.h and what it includes; the other headers are internal -----
install(FILES
  ${CMAKE_SOURCE_DIR}/vdbscatter/include/vdbscatter/vdbscatter.h
  ${CMAKE_SOURCE_DIR}/vdbscatter/include/vdbscatter/export.h
  ${CMAKE_SOURCE_DIR}/vdbscatter/include/vdbscatter/status.h
  ${CMAKE_SOURCE_DIR}/vdbscatter/include/vdbscatter/cancel.h
  DESTINATION ${VDBS_INSTALL_INCLUDEDIR}/vdbscatter)

# --- pkg-config ----------------------------------------------------------------------------
# Libs links the shared library. Libs.private is what a static link (pkg-config --static) adds
# after -lvdbscatter: the lower archives, then the libraries the archives call, spelled out
# here from their own pkg-config files. Not as Requires.private: pkg-config would then add
# their Cflags (-I/usr/include/OpenEXR, -pthread, ...) to every user of the shared library,
# whose headers need none, and fail wherever their development files are missing. prefix= is
# the install prefix, written when installing (--prefix is known only then).
set(VDBS_PC_LIBS_PRIVATE)
foreach(t ${VDBS_STATIC_TARGETS})
  if(NOT t STREQUAL "vdbscatter")
    get_target_property(name ${t} OUTPUT_NAME)
    if(NOT name)
      set(name ${t})
    endif()
    string(APPEND VDBS_PC_LIBS_PRIVATE " -l${name}")
  endif()
endforeach()
execute_process(
  COMMAND ${PKG_CONFIG_EXECUTABLE} --libs epoxy egl libcjson OpenEXR stb lapacke libxxhash tbb
  OUTPUT_VARIABLE VDBS_PC_DEPS_LIBS OUTPUT_STRIP_TRAILING_WHITESPACE
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pkg-config --libs of the library's dependencies failed")
endif()
string(APPEND VDBS_PC_LIBS_PRIVATE " -lopenvdb ${VDBS_PC_DEPS_LIBS} -fopenmp -lstdc++ -lm")
string(REGEX REPLACE "  +" " " VDBS_PC_LIBS_PRIVATE "${VDBS_PC_LIBS_PRIVATE}")
string(STRIP "${VDBS_PC_LIBS_PRIVATE}" VDBS_PC_LIBS_PRIVATE)
set(VDBS_PC_IN ${CMAKE_BINARY_DIR}/pkgconfig/vdbscatter.pc.in)
set(VDBS_PC ${CMAKE_BINARY_DIR}/pkgconfig/vdbscatter.pc)
# First pass now (everything but the prefix, kept as @VDBS_PC_PREFIX@), second pass at
# install time.
set(VDBS_PC_PREFIX "@VDBS_PC_PREFIX@")
configure_file(${CMAKE_SOURCE_DIR}/cmake/vdbscatter.pc.in ${VDBS_PC_IN} @ONLY)
install(CODE "
  set(VDBS_PC_PREFIX \"\${CMAKE_INSTALL_PREFIX}\")
  configure_file(\"${VDBS_PC_IN}\" \"${VDBS_PC}\" @ONLY)")
install(FILES ${VDBS_PC} DESTINATION ${VDBS_INSTALL_LIBDIR}/pkgconfig)

# --- CMake package: find_package(vdbscatter CONFIG) -> vdbscatter::vdbscatter -------------
# Written by hand rather than by install(EXPORT): the imported target is the shared library
# alone, whose dependencies are all private, so the build's static targets and their
# dependencies need not be exported. Paths are relative to the installed config file.
configure_package_config_file(
  ${CMAKE_SOURCE_DIR}/cmake/vdbscatterConfig.cmake.in
  ${CMAKE_BINARY_DIR}/cmake/vdbscatterConfig.cmake.gen
  INSTALL_DESTINATION ${VDBS_INSTALL_CMAKEDIR}
  PATH_VARS VDBS_INSTALL_LIBDIR VDBS_INSTALL_INCLUDEDIR)
# The library's file names (libvdbscatter.so.0.1.0, libvdbscatter.so.0) from the target.
file(GENERATE OUTPUT ${CMAKE_BINARY_DIR}/cmake/vdbscatterConfig.cmake
     INPUT ${CMAKE_BINARY_DIR}/cmake/vdbscatterConfig.cmake.gen)
write_basic_package_version_file(
  ${CMAKE_BINARY_DIR}/cmake/vdbscatterConfigVersion.cmake
  VERSION ${PROJECT_VERSION}
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/cmake/vdbscatterConfig.cmake
              ${CMAKE_BINARY_DIR}/cmake/vdbscatterConfigVersion.cmake
        DESTINATION ${VDBS_INSTALL_CMAKEDIR})

# --- Python package ------------------------------------------------------------------------
# Where the system Python looks for pure modules under a prefix other than its own: Debian's
# scheme for /usr/local (posix_local) read relative to that prefix, lib/python3.X/dist-packages,
# so that the default prefix /usr/local needs no PYTHONPATH; elsewhere the interpreter's
# default scheme relative to its base (lib/python3.X/site-packages). The package finds the
# library by walking up from its folder to PREFIX/lib.
find_program(VDBS_SYSTEM_PYTHON NAMES python3 PATHS /usr/bin NO_DEFAULT_PATH)
if(NOT VDBS_SYSTEM_PYTHON)
  find_program(VDBS_SYSTEM_PYTHON NAMES python3 REQUIRED)
endif()
if(NOT DEFINED CACHE{VDBSCATTER_INSTALL_PYTHONDIR})
  execute_process(
    COMMAND ${VDBS_SYSTEM_PYTHON} -c [=[
import os, sysconfig
scheme = sysconfig.get_default_scheme() if hasattr(sysconfig, "get_default_scheme") \
    else sysconfig._get_default_scheme()
base = "/PREFIX"
path = sysconfig.get_path("purelib", scheme, vars={"base": base, "platbase": base})
if scheme == "posix_local":  # Debian: {base}/local/lib/python3.X/dist-packages
    base += "/local"
print(os.path.relpath(path, base), end="")
]=]
    OUTPUT_VARIABLE VDBS_PYTHONDIR
    RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0 OR VDBS_PYTHONDIR STREQUAL "" OR VDBS_PYTHONDIR MATCHES "^\\.\\.")
    message(FATAL_ERROR "Cannot tell the Python package folder from ${VDBS_SYSTEM_PYTHON} "
                        "(got '${VDBS_PYTHONDIR}'); set VDBSCATTER_INSTALL_PYTHONDIR")
  endif()
endif()
set(VDBSCATTER_INSTALL_PYTHONDIR "${VDBS_PYTHONDIR}" CACHE STRING
    "Folder of the Python package vdbscatter, relative to the install prefix")
install(DIRECTORY ${CMAKE_SOURCE_DIR}/python/vdbscatter
        DESTINATION ${VDBSCATTER_INSTALL_PYTHONDIR}
        FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)

# --- man pages, from --help by help2man (built with the tools, copied by install) ---------
# scripts/man.sh stands in for a command: help2man runs it with --help and --version.
find_program(VDBS_HELP2MAN help2man)
if(NOT VDBS_HELP2MAN)
  message(FATAL_ERROR "help2man not found: it makes the man pages (bash scripts/setup.sh "
                      "installs it)")
endif()
set(VDBS_MAN_DIR ${CMAKE_BINARY_DIR}/man)
set(VDBS_MAN_PAGES)
set(VDBS_MAN_SEE_ALSO ${VDBS_MAN_DIR}/see_also.h2m)
# page|tool target|subcommand|NAME line (the top-level --help's summaries)
set(VDBS_MAN_LIST
  "vdbscatter|vdbscatter_cli||light density VDBs (single and multiple scattering) and render them"
  "vdbscatter-bake|vdbscatter_cli|bake|light a density VDB and write a lit VDB"
  "vdbscatter-render|vdbscatter_cli|render|ray-march or path-trace a picture of a volume"
  "vdbscatter-compare|vdbscatter_cli|compare|error metrics of image A against reference B"
  "vdbscatter-info|vdbscatter_cli|info|list grids, sizes, value ranges, optical thickness"
  "vdbscatter-sample|vdbscatter_cli|sample|write a procedural sample volume"
  "vdbscatter-tradeoff|vdbscatter_cli|tradeoff|every method's error against time on your scene"
  "vdbscatter-phase-svd|vdbscatter_cli|phase-svd|the phase matrix's factorisation error per term"
  "vdbscatter-view|vdbscatter_view||show a lit VDB interactively")
set(see_also "[SEE ALSO]\n")
foreach(entry ${VDBS_MAN_LIST})
  string(REPLACE "|" ";" entry "${entry}")
  list(GET entry 0 page)
  string(APPEND see_also ".BR ${page} (1)\n")
endforeach()
file(CONFIGURE OUTPUT ${VDBS_MAN_SEE_ALSO} CONTENT "${see_also}" @ONLY)
foreach(entry ${VDBS_MAN_LIST})
  string(REPLACE "|" ";" entry "${entry}")
  list(GET entry 0 page)
  list(GET entry 1 tool)
  list(GET entry 2 command)
  list(GET entry 3 summary)
  # help2man names the page after the program it runs: a wrapper of that name.
  set(wrapper ${VDBS_MAN_DIR}/bin/${page})
  file(GENERATE OUTPUT ${wrapper}
       CONTENT "#!/bin/sh\nexec /bin/bash '${CMAKE_SOURCE_DIR}/scripts/man.sh' '${page}' \
'${PROJECT_VERSION}' '$<TARGET_FILE:${tool}>' ${command} \"$@\"\n"
       FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE)
  set(out ${VDBS_MAN_DIR}/man1/${page}.1)
  add_custom_command(
    OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${VDBS_MAN_DIR}/man1
    # A sanitizer build's tools run here too: no leak report may change their exit status.
    COMMAND ${CMAKE_COMMAND} -E env ASAN_OPTIONS=detect_leaks=0
            ${VDBS_HELP2MAN} --no-info --section 1 --name ${summary}
            --include ${VDBS_MAN_SEE_ALSO} --output ${out} ${wrapper}
    DEPENDS ${tool} ${wrapper} ${VDBS_MAN_SEE_ALSO} ${CMAKE_SOURCE_DIR}/scripts/man.sh
    COMMENT "Man page ${page}.1"
    VERBATIM)
  list(APPEND VDBS_MAN_PAGES ${out})
endforeach()
add_custom_target(vdbscatter_man ALL DEPENDS ${VDBS_MAN_PAGES})
install(FILES ${VDBS_MAN_PAGES} DESTINATION ${VDBS_INSTALL_MANDIR}/man1)
