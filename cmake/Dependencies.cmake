# All dependencies are system packages (Debian 12 / Ubuntu 24.04); nothing is downloaded.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(HDF5 REQUIRED COMPONENTS C)
find_package(yaml-cpp REQUIRED)
find_package(PNG REQUIRED)
find_package(ZLIB REQUIRED)  # the .vtu reader's compressed arrays
find_package(CLI11 REQUIRED)
find_package(Threads REQUIRED)
# OpenMP parallelises per-element loops; every parallel loop gathers in a fixed order so results
# are bitwise identical for any thread count.
find_package(OpenMP REQUIRED COMPONENTS CXX)

# yaml-cpp 0.7 exports `yaml-cpp`, 0.8 `yaml-cpp::yaml-cpp`.
if(TARGET yaml-cpp::yaml-cpp)
  set(EBH_YAML_TARGET yaml-cpp::yaml-cpp)
else()
  set(EBH_YAML_TARGET yaml-cpp)
endif()

add_library(ebh_hdf5 INTERFACE)
target_include_directories(ebh_hdf5 SYSTEM INTERFACE ${HDF5_INCLUDE_DIRS})
target_link_libraries(ebh_hdf5 INTERFACE ${HDF5_C_LIBRARIES})
target_compile_definitions(ebh_hdf5 INTERFACE ${HDF5_DEFINITIONS})

# OSMesa is optional: without it `ebh render` reports what is missing.
set(EBH_HAVE_OSMESA OFF)
if(EBH_WITH_OSMESA)
  find_package(PkgConfig)
  if(PkgConfig_FOUND)
    pkg_check_modules(OSMESA IMPORTED_TARGET osmesa)
    if(OSMESA_FOUND)
      set(EBH_HAVE_OSMESA ON)
    endif()
  endif()
endif()
message(STATUS "ebh: OSMesa rendering: ${EBH_HAVE_OSMESA}")

# CUDA is optional: the backend builds when nvcc is found.
set(EBH_HAVE_CUDA OFF)
if(EBH_WITH_CUDA)
  include(CheckLanguage)
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
      set(CMAKE_CUDA_ARCHITECTURES 90)
    endif()
    enable_language(CUDA)
    set(CMAKE_CUDA_STANDARD 20)
    set(CMAKE_CUDA_STANDARD_REQUIRED ON)
    find_package(CUDAToolkit REQUIRED)
    set(EBH_HAVE_CUDA ON)
  endif()
endif()
message(STATUS "ebh: CUDA backend: ${EBH_HAVE_CUDA}")

if(EBH_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(EBH_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()
