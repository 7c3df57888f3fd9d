# Rules every library and program of the package follows (docs/design.md, "Modules").
#
# htr_ros_free_library(NAME SOURCES ... LINKS ...)
#   A library of the ROS-free core (or of the simulator / evaluation, which are ROS-free too):
#   it sees the package's headers, Eigen and OpenCV, and no ROS include directory. Debian installs
#   ROS headers under /usr/include, which every compiler searches, so leaving the ROS include
#   directories off is not enough: the target also gets, before every other directory, a folder of
#   stand-ins for every ROS header (generated below) that stop the compilation with an #error
#   naming the rule. A core source that includes <ros/ros.h> therefore fails to compile
#   (ctest core_cannot_include_ros_headers).
#
# htr_ros_target(NAME)
#   A node, nodelet or ROS tool: gets catkin's include directories and libraries, and waits for
#   the generated messages, actions and dynamic_reconfigure headers.

# --- stand-ins for the ROS headers -----------------------------------------------------------
# Every ROS package installed beside roscpp (a share/<package>/package.xml under its prefix) whose
# headers live in include/<package>/, plus roscpp's include/ros/. catkin leaves /usr/include out of
# catkin_INCLUDE_DIRS (a system directory), so the prefix comes from where ros/ros.h is.
set(HTR_ROS_HEADER_GUARD_DIR ${CMAKE_BINARY_DIR}/ros_header_guard)
function(htr_generate_ros_header_guard)
  find_path(HTR_ROSCPP_INCLUDE_DIR ros/ros.h HINTS ${roscpp_INCLUDE_DIRS} ${catkin_INCLUDE_DIRS})
  if(NOT HTR_ROSCPP_INCLUDE_DIR)
    message(FATAL_ERROR "ros/ros.h not found: is roscpp installed?")
  endif()
  set(include_dirs ${HTR_ROSCPP_INCLUDE_DIR} ${catkin_INCLUDE_DIRS})
  list(REMOVE_DUPLICATES include_dirs)
  set(folders ros)
  foreach(include_dir ${include_dirs})
    get_filename_component(prefix "${include_dir}/.." ABSOLUTE)
    file(GLOB manifests "${prefix}/share/*/package.xml")
    foreach(manifest ${manifests})
      get_filename_component(package_dir "${manifest}" DIRECTORY)
      get_filename_component(package "${package_dir}" NAME)
      if(IS_DIRECTORY "${include_dir}/${package}")
        list(APPEND folders ${package})
      endif()
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES folders)
  set(count 0)
  foreach(include_dir ${include_dirs})
    foreach(folder ${folders})
      file(GLOB_RECURSE headers RELATIVE "${include_dir}" "${include_dir}/${folder}/*.h" "${include_dir}/${folder}/*.hpp")
      foreach(header ${headers})
        set(guard "${HTR_ROS_HEADER_GUARD_DIR}/${header}")
        if(NOT EXISTS "${guard}")
          file(WRITE "${guard}"
               "#error \"the ROS-free core must not include a ROS header (<${header}>): see docs/design.md\"\n")
        endif()
        math(EXPR count "${count} + 1")
      endforeach()
    endforeach()
  endforeach()
  list(LENGTH folders folder_count)
  message(STATUS "ROS header guard: ${count} headers of ${folder_count} ROS packages are refused in the core")
endfunction()
htr_generate_ros_header_guard()

function(htr_ros_free_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LINKS" ${ARGN})
  add_library(${name} ${ARG_SOURCES})
  htr_ros_free_settings(${name})
  target_link_libraries(${name} PUBLIC ${ARG_LINKS})
endfunction()

# The include rules of the ROS-free code, for a library or a program.
function(htr_ros_free_settings name)
  target_include_directories(${name} BEFORE PRIVATE ${HTR_ROS_HEADER_GUARD_DIR})
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>)
  target_include_directories(${name} SYSTEM PUBLIC ${EIGEN3_INCLUDE_DIRS} ${OpenCV_INCLUDE_DIRS})
endfunction()

# (The caller links ${catkin_LIBRARIES}: catkin's test macros link with the plain signature,
# which CMake does not let one mix with PUBLIC/PRIVATE on one target.)
function(htr_ros_target name)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/include ${CATKIN_DEVEL_PREFIX}/include)
  target_include_directories(${name} SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
  add_dependencies(${name} ${${PROJECT_NAME}_EXPORTED_TARGETS} ${catkin_EXPORTED_TARGETS})
endfunction()
