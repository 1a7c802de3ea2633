# cmake -DVIEWER_DIR=<repo>/viewer -DOUTPUT=<build>/viewer/dsnake_viewer.js -P bundle.cmake
# Runs the esbuild that viewer/package-lock.json pins (viewer/node_modules) on src/viewer.js:
# one minified IIFE defining the global DsnakeViewer, three.js's licence comment kept at its end.
# The same command by hand, from viewer/: npm run build (writes build/release/viewer/).
set(esbuild ${VIEWER_DIR}/node_modules/.bin/esbuild)
if(NOT EXISTS ${esbuild})
  message(FATAL_ERROR "dsnake_viewer: ${esbuild} is missing: the viewer's npm packages are not installed; "
                      "run scripts/setup.sh (it runs `npm ci --prefix viewer`)")
endif()
execute_process(
  COMMAND ${esbuild} src/viewer.js --bundle --minify --format=iife --global-name=DsnakeViewer
          --target=es2020 --legal-comments=eof --log-level=warning --outfile=${OUTPUT}
  WORKING_DIRECTORY ${VIEWER_DIR}
  RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "dsnake_viewer: esbuild failed (${status}) on ${VIEWER_DIR}/src/viewer.js")
endif()
