# Warnings go through an interface target so generated code (IDL) is spared.
add_library(thermovis_warnings INTERFACE)
add_library(thermovis::warnings ALIAS thermovis_warnings)
target_compile_options(thermovis_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Woverloaded-virtual -Wformat=2
  $<$<BOOL:${THERMOVIS_WERROR}>:-Werror>)
# GCC 12's flow-sensitive string/bounds checks report false positives inside libstdc++
# at -O2/-O3 (std::string operator+, std::vector growth): they stay warnings, never errors.
if(THERMOVIS_WERROR AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  target_compile_options(thermovis_warnings INTERFACE
    -Wno-error=restrict -Wno-error=array-bounds -Wno-error=stringop-overflow
    -Wno-error=stringop-overread -Wno-error=maybe-uninitialized)
endif()

# Subfolders that hold a CMakeLists.txt are added in name order; a new library or service
# is a new folder, nothing else to edit.
function(thermovis_add_subdirectories)
  file(GLOB children LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}
       CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*)
  list(SORT children)
  foreach(child IN LISTS children)
    if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${child}
       AND EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${child}/CMakeLists.txt)
      add_subdirectory(${child})
    endif()
  endforeach()
endfunction()

# thermovis_add_library(NAME <name> SOURCES ... [PUBLIC_LIBS ...] [PRIVATE_LIBS ...])
# Makes thermovis_<name> with alias thermovis::<name>, public headers in include/.
function(thermovis_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  add_library(thermovis_${ARG_NAME} ${ARG_SOURCES})
  add_library(thermovis::${ARG_NAME} ALIAS thermovis_${ARG_NAME})
  target_include_directories(thermovis_${ARG_NAME} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
  target_link_libraries(thermovis_${ARG_NAME} PUBLIC ${ARG_PUBLIC_LIBS}
    PRIVATE ${ARG_PRIVATE_LIBS} thermovis::warnings)
endfunction()

# thermovis_add_service(NAME <executable> SOURCES ... [LIBS ...])
# A pipeline service's executable, linked with the node layer (thermovis::node and
# thermovis::runtime) and LIBS; none when THERMOVIS_WITH_DDS is off.
function(thermovis_add_service)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;LIBS" ${ARGN})
  if(NOT THERMOVIS_WITH_DDS)
    return()
  endif()
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE thermovis::node ${ARG_LIBS} thermovis::runtime
    thermovis::warnings)
endfunction()

# thermovis_add_cyclone_idl(<library> FILES <idl files>)
# A static library of the C types Cyclone DDS's idlc generates from FILES (paths under
# THERMOVIS_IDL_ROOT) at build time, for Cyclone DDS C-API clients; the generated C is compiled
# once and without the project's warning flags. Needs find_package(CycloneDDS) first.
function(thermovis_add_cyclone_idl library)
  cmake_parse_arguments(ARG "" "" "FILES" ${ARGN})
  idlc_generate(TARGET ${library}_sources
    FILES ${ARG_FILES}
    BASE_DIR ${THERMOVIS_IDL_ROOT}
    INCLUDES ${THERMOVIS_IDL_ROOT})
  get_target_property(sources ${library}_sources INTERFACE_SOURCES)
  add_library(${library} STATIC ${sources})
  add_dependencies(${library} ${library}_sources_generate)
  target_include_directories(${library} SYSTEM PUBLIC ${CMAKE_CURRENT_BINARY_DIR})
  target_link_libraries(${library} PUBLIC CycloneDDS::ddsc)
endfunction()
