# SPDX-License-Identifier: Apache-2.0
# cmake -DSRC=web -DOUT=<build>/web -DTHREE=<three.module.js> -P copy_web.cmake
if(NOT EXISTS ${THREE})
  message(FATAL_ERROR "three.js is missing (${THREE}): run `npm ci --prefix web` "
                      "(tools/bootstrap.sh does it)")
endif()
file(MAKE_DIRECTORY ${OUT}/js ${OUT}/vendor ${OUT}/network)
file(COPY ${SRC}/index.html ${SRC}/style.css ${SRC}/network.css DESTINATION ${OUT})
file(COPY ${SRC}/network/index.html DESTINATION ${OUT}/network)
file(COPY ${SRC}/js/ DESTINATION ${OUT}/js)
file(COPY ${THREE} DESTINATION ${OUT}/vendor)
file(COPY ${SRC}/node_modules/three/LICENSE DESTINATION ${OUT}/vendor)
