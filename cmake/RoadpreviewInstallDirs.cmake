# Where things are installed. A plain `cmake --install` uses the GNU layout under CMAKE_INSTALL_PREFIX;
# a Python wheel (scikit-build-core) puts the library, headers and CMake package inside the `roadpreview`
# package directory (so `roadpreview.cmake_dir()` finds them) and the CLI in the environment's scripts dir.
include(GNUInstallDirs)
if(SKBUILD)
  set(ROADPREVIEW_INSTALL_LIBDIR roadpreview/lib)
  set(ROADPREVIEW_INSTALL_INCLUDEDIR roadpreview/include)
  set(ROADPREVIEW_INSTALL_BINDIR ${SKBUILD_SCRIPTS_DIR})
else()
  set(ROADPREVIEW_INSTALL_LIBDIR ${CMAKE_INSTALL_LIBDIR})
  set(ROADPREVIEW_INSTALL_INCLUDEDIR ${CMAKE_INSTALL_INCLUDEDIR})
  set(ROADPREVIEW_INSTALL_BINDIR ${CMAKE_INSTALL_BINDIR})
endif()
set(ROADPREVIEW_INSTALL_CMAKEDIR ${ROADPREVIEW_INSTALL_LIBDIR}/cmake/roadpreview)
# The shared libraries' version properties. A wheel cannot hold symlinks: versioned, each library would be there
# three times (libX.so, libX.so.0, libX.so.0.1.0, full copies), so in a wheel each is one file without a version.
if(SKBUILD)
  set(ROADPREVIEW_LIBRARY_VERSION)
else()
  set(ROADPREVIEW_LIBRARY_VERSION VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR})
endif()
