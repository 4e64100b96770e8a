# Every third-party dependency of printtwin is found here, and only here.
# All come from Debian 12 packages (see scripts/setup.sh for the list).

find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Threads REQUIRED)
find_package(TBB REQUIRED)

# CGAL 5.5 is header-only; it is kept in few translation units (compile time).
set(CGAL_DO_NOT_WARN_ABOUT_CMAKE_BUILD_TYPE TRUE)
find_package(CGAL 5.5 REQUIRED)
find_package(assimp REQUIRED)
find_package(octomap REQUIRED)
find_package(embree 3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(fmt REQUIRED)
find_package(PNG REQUIRED)
find_package(ZLIB REQUIRED)  # deflate blocks of binary G-code

find_package(PkgConfig REQUIRED)
pkg_check_modules(POLYCLIPPING REQUIRED IMPORTED_TARGET polyclipping)
# Deflate blocks and CRC32 of binary G-code, 2-3x faster than zlib (zlib is its plain twin).
pkg_check_modules(LIBDEFLATE REQUIRED IMPORTED_TARGET libdeflate)


find_path(STB_INCLUDE_DIR stb/stb_image_write.h)

if(PRINTTWIN_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(PRINTTWIN_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
