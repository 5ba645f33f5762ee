# Every dependency comes from Debian 12 packages (tools/setup.sh installs them).
# A missing one stops the configure step with the name of the package to install.

function(capsflow_require package debian_package)
  if(NOT ${package}_FOUND)
    message(FATAL_ERROR "capsflow: ${package} not found; install the Debian package "
                        "'${debian_package}' (or run tools/setup.sh)")
  endif()
endfunction()

find_package(Eigen3 3.4 QUIET NO_MODULE)
capsflow_require(Eigen3 libeigen3-dev)

find_package(OpenMP QUIET COMPONENTS CXX)
capsflow_require(OpenMP "g++ (libgomp)")

find_package(MPI QUIET COMPONENTS CXX)
capsflow_require(MPI "libopenmpi-dev openmpi-bin")

set(HDF5_PREFER_PARALLEL TRUE)
find_package(HDF5 QUIET COMPONENTS C)
capsflow_require(HDF5 libhdf5-openmpi-dev)

find_package(VTK 9 QUIET COMPONENTS CommonCore CommonDataModel IOGeometry IOXML IOParallelXML ParallelMPI)
capsflow_require(VTK libvtk9-dev)

find_package(tomlplusplus QUIET)
capsflow_require(tomlplusplus libtomlplusplus-dev)

find_package(CLI11 QUIET)
capsflow_require(CLI11 libcli11-dev)

find_package(fmt QUIET)
capsflow_require(fmt libfmt-dev)

if(CAPSFLOW_BUILD_TESTS)
  find_package(GTest QUIET)
  capsflow_require(GTest "libgtest-dev libgmock-dev")
endif()
if(CAPSFLOW_BUILD_BENCH)
  find_package(benchmark QUIET)
  capsflow_require(benchmark libbenchmark-dev)
endif()
