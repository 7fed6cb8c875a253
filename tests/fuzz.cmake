# Mutation test of the mesh readers (tests/mesh/fuzz/mesh_fuzz.cpp). The reader sources are
# compiled into the test directly, with AddressSanitizer and UBSan, instead of linking the normal
# ebh_mesh: any memory error or undefined behaviour on a mutated file aborts the test.
file(GLOB EBH_MESH_FUZZ_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/lib/mesh/*.cpp)
add_executable(test_mesh_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/mesh/fuzz/mesh_fuzz.cpp ${EBH_MESH_FUZZ_SOURCES})
target_include_directories(test_mesh_fuzz PRIVATE ${PROJECT_SOURCE_DIR}/lib ${PROJECT_BINARY_DIR}/generated)
target_compile_options(test_mesh_fuzz PRIVATE -fsanitize=address,undefined -fno-sanitize-recover=all
                       -fno-omit-frame-pointer -g)
target_link_options(test_mesh_fuzz PRIVATE -fsanitize=address,undefined)
target_link_libraries(test_mesh_fuzz PRIVATE ebh_warnings ZLIB::ZLIB)
add_test(NAME mesh.fuzz COMMAND test_mesh_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh 10000)  # 1-2 s of CPU with the sanitizers
set_tests_properties(mesh.fuzz PROPERTIES LABELS mesh TIMEOUT 300
                     ENVIRONMENT "ASAN_OPTIONS=abort_on_error=0:detect_leaks=1;UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1")

# The same for the ROS bag reader (tests/io/fuzz/bag_fuzz.cpp), with the bag codecs it links.
add_executable(test_bag_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/io/fuzz/bag_fuzz.cpp ${PROJECT_SOURCE_DIR}/lib/io/rosbag.cpp)
target_include_directories(test_bag_fuzz PRIVATE ${PROJECT_SOURCE_DIR}/lib ${PROJECT_BINARY_DIR}/generated)
target_compile_options(test_bag_fuzz PRIVATE -fsanitize=address,undefined -fno-sanitize-recover=all
                       -fno-omit-frame-pointer -g)
target_link_options(test_bag_fuzz PRIVATE -fsanitize=address,undefined)
target_link_libraries(test_bag_fuzz PRIVATE ebh_warnings ebh_bag_codecs Eigen3::Eigen)
add_test(NAME io.bag_fuzz COMMAND test_bag_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/data/io 2000)
set_tests_properties(io.bag_fuzz PROPERTIES LABELS io TIMEOUT 300
                     ENVIRONMENT "ASAN_OPTIONS=abort_on_error=0:detect_leaks=1;UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1")
