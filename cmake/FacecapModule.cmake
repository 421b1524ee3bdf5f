# facecap_module(NAME DEPS a b PRIVATE_DEPS c d)
# One static library per module from src/NAME/*.cpp (tests excluded), and one GoogleTest
# binary facecap_NAME_test from src/NAME/*_test.cpp, registered with CTest under the label
# "unit" (and "long" for tests whose names contain Long).
function(facecap_module name)
  cmake_parse_arguments(ARG "" "" "DEPS;PRIVATE_DEPS" ${ARGN})
  set(dir ${CMAKE_CURRENT_SOURCE_DIR}/${name})
  file(GLOB sources CONFIGURE_DEPENDS ${dir}/*.cpp)
  list(FILTER sources EXCLUDE REGEX "_test\\.cpp$")
  # A module's main.cpp is the program built from it, not part of its library.
  list(FILTER sources EXCLUDE REGEX "/main\\.cpp$")
  if(NOT sources)
    # A header-only module (or one not yet written): an INTERFACE target keeps the graph.
    add_library(facecap_${name} INTERFACE)
    target_include_directories(facecap_${name} INTERFACE ${PROJECT_SOURCE_DIR}/src)
    target_link_libraries(facecap_${name} INTERFACE ${ARG_DEPS})
    return()
  endif()
  add_library(facecap_${name} STATIC ${sources})
  target_include_directories(facecap_${name} PUBLIC ${PROJECT_SOURCE_DIR}/src)
  target_link_libraries(facecap_${name} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS}
                        facecap_warnings)
  if(FACECAP_BUILD_TESTS)
    file(GLOB tests CONFIGURE_DEPENDS ${dir}/*_test.cpp)
    if(tests)
      add_executable(facecap_${name}_test ${tests})
      set_target_properties(facecap_${name}_test PROPERTIES RUNTIME_OUTPUT_DIRECTORY
                            ${CMAKE_BINARY_DIR}/tests)
      target_link_libraries(facecap_${name}_test PRIVATE facecap_${name} ${ARG_PRIVATE_DEPS}
                            facecap_gtest_main GTest::gtest GTest::gmock facecap_warnings)
      gtest_discover_tests(facecap_${name}_test PROPERTIES LABELS unit
                           WORKING_DIRECTORY ${CMAKE_BINARY_DIR}/tests
                           DISCOVERY_TIMEOUT 60)
    endif()
  endif()
endfunction()
