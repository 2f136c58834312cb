# SPDX-License-Identifier: GPL-3.0-or-later
# Warnings and sanitizer flags for this project's own targets only.
# IIRES_SANITIZE: AddressSanitizer + UndefinedBehaviorSanitizer; every UBSan finding aborts the program
# (-fno-sanitize-recover=all), so a test that triggers one fails instead of passing with a printed report.
set(IIRES_SANITIZE_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
function(iires_target_options target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wno-deprecated-declarations)
  if(IIRES_SANITIZE)
    target_compile_options(${target} PRIVATE ${IIRES_SANITIZE_FLAGS})
    target_link_options(${target} PRIVATE ${IIRES_SANITIZE_FLAGS})
  endif()
endfunction()

# A library built on libiires (libregister, libreconstruct): sources globbed from src/, public headers in
# include/, target iires_<short> with alias and export name iires::<short>; third-party types stay private.
function(iires_add_dependent_library short)
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  if(NOT sources)
    return()
  endif()
  add_library(iires_${short} SHARED ${sources})
  add_library(iires::${short} ALIAS iires_${short})
  set_target_properties(iires_${short} PROPERTIES EXPORT_NAME ${short})
  target_include_directories(iires_${short} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(iires_${short} PUBLIC iires::iires PRIVATE OpenMP::OpenMP_CXX ${ARGN})
  iires_target_options(iires_${short})
  install(TARGETS iires_${short} EXPORT iiresTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()
