# SPDX-License-Identifier: Apache-2.0
# cmake -DSRC=web -DOUT=<build>/web -DTHREE=<three.module.js> -DLIB=<satellite/js/src> -P copy_web.cmake
# LIB: the JavaScript library, served at /skrobot/ for the pages (import '/skrobot/index.js').
if(NOT EXISTS ${THREE})
  message(FATAL_ERROR "three.js is missing (${THREE}): run `npm ci --prefix web` "
                      "(tools/bootstrap.sh does it)")
endif()
file(MAKE_DIRECTORY ${OUT}/vendor ${OUT}/network)
file(COPY ${SRC}/index.html ${SRC}/style.css ${SRC}/network.css DESTINATION ${OUT})
file(COPY ${SRC}/network/index.html DESTINATION ${OUT}/network)
file(REMOVE_RECURSE ${OUT}/js)  # a file deleted from web/js goes from the copy too
file(COPY ${SRC}/js/ DESTINATION ${OUT}/js)
file(COPY ${THREE} DESTINATION ${OUT}/vendor)
file(REMOVE_RECURSE ${OUT}/skrobot)  # a file deleted from the library goes from the copy too
file(COPY ${LIB}/ DESTINATION ${OUT}/skrobot)
file(COPY ${SRC}/node_modules/three/LICENSE DESTINATION ${OUT}/vendor)
