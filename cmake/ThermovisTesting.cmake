# thermovis_add_gtest(NAME <exe> SOURCES ... LIBS ... LABEL unit|integration|lab|bench [TIMEOUT s]
#                     [SERIAL])
# One CTest entry per test case, each with a label, a timeout and the test-data location.
# SERIAL: its tests run with nothing else beside them (RUN_SERIAL), not even unit tests.
function(thermovis_add_gtest)
  cmake_parse_arguments(ARG "SERIAL" "NAME;LABEL;TIMEOUT" "SOURCES;LIBS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LIBS} thermovis::test_support
    GTest::gtest GTest::gtest_main thermovis::warnings)
  # Tests that start a whole pipeline (integration, lab, soak) never run at the same time as one
  # another: one pipeline saturates this project's 2-core reference machine, and two at once
  # would measure the machine, not the code. Unit tests still run beside them.
  set(lock "")
  if(ARG_LABEL MATCHES "^(integration|lab|soak)$")
    set(lock RESOURCE_LOCK pipeline)
  endif()
  if(ARG_SERIAL)
    list(APPEND lock RUN_SERIAL TRUE)
  endif()
  gtest_discover_tests(${ARG_NAME}
    DISCOVERY_TIMEOUT 60
    PROPERTIES LABELS ${ARG_LABEL} TIMEOUT ${ARG_TIMEOUT} ${lock}
               # XDG_CACHE_HOME: the simulated bridge's set-up cache (--sim-cache auto, ~200 MB
               # a file) stays in the build tree, shared by the tests, not in the user's home.
               ENVIRONMENT "THERMOVIS_BIN_DIR=${PROJECT_BINARY_DIR}/bin;THERMOVIS_SOURCE_DIR=${PROJECT_SOURCE_DIR};XDG_CACHE_HOME=${PROJECT_BINARY_DIR}/test-cache")
endfunction()

# thermovis_add_benchmark(NAME <exe> SOURCES ... LIBS ...): Google Benchmark executable,
# registered as one CTest entry labelled bench that runs each benchmark briefly (a smoke run;
# the figures come from running the executable itself).
function(thermovis_add_benchmark)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;LIBS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SOURCES} ${PROJECT_SOURCE_DIR}/tests/bench/heap_policy.cpp)
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LIBS} thermovis::test_support thermovis::util
    benchmark::benchmark thermovis::warnings)
  add_test(NAME ${ARG_NAME}.smoke COMMAND ${ARG_NAME} --benchmark_min_time=0.01)
  set_tests_properties(${ARG_NAME}.smoke PROPERTIES LABELS bench TIMEOUT 600)
endfunction()
