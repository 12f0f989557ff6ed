# Warnings are errors on our own code.
function(loam_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Werror -Wshadow -Wconversion
                                           -Wno-sign-conversion)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # GCC 12 at -O3 reports impossible overlaps inside std::string's inlined memcpy
    # ("lit" + std::string, GCC bug 105651): a false positive, not an error of ours.
    target_compile_options(${target} PRIVATE -Wno-restrict)
    # In a unity build each .cpp is included into the batch, so GCC takes its anonymous-namespace
    # types for a header's and warns where a lambda or template of the file captures them.
    if(CMAKE_UNITY_BUILD)
      target_compile_options(${target} PRIVATE -Wno-subobject-linkage)
    endif()
  endif()
endfunction()

# Compile settings every Loam target shares: the warnings, and includes from the project root.
function(loam_target_defaults target)
  loam_warnings(${target})
  target_include_directories(${target} PUBLIC ${PROJECT_SOURCE_DIR})
endfunction()

# Code whose floating-point results must be identical on every compiler and platform
# (stamp profile tables, quantization): no fused multiply-add contraction.
function(loam_exact_fp target)
  target_compile_options(${target} PRIVATE -ffp-contract=off -fno-fast-math)
endfunction()

# The hot numeric code the tests run most (protocol/: stamp kernels, codec, refinement): in the
# sanitizer build it keeps -O2 over that build's -O1, so the tests exercise it as optimized as
# users get it.
function(loam_hot_code target)
  if(LOAM_SANITIZE)
    target_compile_options(${target} PRIVATE -O2)
  endif()
endfunction()

# Code that drives the code under test rather than being it: test bodies, the benchmark harness
# and the programs' command-line front ends. In the sanitizer build (the test configuration) it
# compiles at -Og: the instrumented optimizer passes, not parsing, are most of that build, and
# -Og takes a test unity batch from 48 s to 18 s (bench/results/build.md).
function(loam_driver_code target)
  if(LOAM_SANITIZE)
    target_compile_options(${target} PRIVATE -Og)
  endif()
endfunction()
