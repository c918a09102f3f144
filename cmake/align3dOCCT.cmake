# OpenCASCADE (OCCT) for align3d's STEP and IGES reader (ALIGN3D_OCCT): the module
# libalign3d_occt.so (src/io/occt/) links it, and the tests that write CAD files. Included by
# CMakeLists.txt and tests/CMakeLists.txt; the core and its users do not link OCCT.
#
#   align3d_occt_target(<target> <toolkit>...)
#     Finds the OCCT headers (ALIGN3D_OCCT_INCLUDE_DIR, <prefix>/include/opencascade) and the
#     shared toolkits named, and makes <target> an imported interface target that links them (no
#     include directories: only the module and the tests include OCCT, and they add
#     ALIGN3D_OCCT_INCLUDE_DIR themselves). Sets ALIGN3D_OCCT_FOUND, and ALIGN3D_OCCT_MISSING to
#     what was not found. A non-standard OCCT is found through CMAKE_PREFIX_PATH.
#
# Not OCCT's own OpenCASCADEConfig.cmake: asked for the modules the reader needs (COMPONENTS
# FoundationClasses ModelingData ModelingAlgorithms DataExchange), Debian 12's 7.6.3 fails
# ("imported targets are referenced, but are missing: TKService TKV3d TKCDF ...": DataExchange's
# targets name Visualization and ApplicationFramework toolkits); asked for everything, it works
# there but defines some 50 imported targets, each checked for its file, for the eight the reader
# links. A find_path and one find_library per toolkit need only those.

# The reader is written against and tested with 7.6 (Debian 12's 7.6.3); older releases changed the
# messenger's and the mesher's interfaces it uses, and are not tested.
set(ALIGN3D_OCCT_MIN_VERSION 7.6)

function(align3d_occt_target target)
  find_path(ALIGN3D_OCCT_INCLUDE_DIR Standard_Version.hxx PATH_SUFFIXES opencascade
            DOC "Directory of the OpenCASCADE headers (Standard_Version.hxx)")
  set(missing "")
  set(libraries "")
  if(ALIGN3D_OCCT_INCLUDE_DIR)
    file(STRINGS "${ALIGN3D_OCCT_INCLUDE_DIR}/Standard_Version.hxx" version_line
         REGEX "^#define OCC_VERSION_COMPLETE ")
    string(REGEX MATCH "[0-9]+\\.[0-9]+(\\.[0-9]+)?" version "${version_line}")
    set(ALIGN3D_OCCT_VERSION "${version}" PARENT_SCOPE)
    if(NOT version OR version VERSION_LESS ALIGN3D_OCCT_MIN_VERSION)
      list(APPEND missing "OpenCASCADE >= ${ALIGN3D_OCCT_MIN_VERSION} (found '${version}')")
    endif()
  else()
    list(APPEND missing "the headers (opencascade/Standard_Version.hxx)")
  endif()
  foreach(toolkit IN LISTS ARGN)
    find_library(ALIGN3D_OCCT_${toolkit}_LIBRARY ${toolkit})
    if(ALIGN3D_OCCT_${toolkit}_LIBRARY)
      list(APPEND libraries "${ALIGN3D_OCCT_${toolkit}_LIBRARY}")
    else()
      list(APPEND missing ${toolkit})
    endif()
  endforeach()
  set(ALIGN3D_OCCT_MISSING "${missing}" PARENT_SCOPE)
  if(missing)
    set(ALIGN3D_OCCT_FOUND FALSE PARENT_SCOPE)
    return()
  endif()
  set(ALIGN3D_OCCT_FOUND TRUE PARENT_SCOPE)
  if(NOT TARGET ${target})
    add_library(${target} INTERFACE IMPORTED)
    set_target_properties(${target} PROPERTIES INTERFACE_LINK_LIBRARIES "${libraries}")
  endif()
endfunction()
