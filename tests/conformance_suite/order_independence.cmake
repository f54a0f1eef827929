# Verdicts must not depend on the order the vectors run in (FORMAT.md "Isolation"): for each
# named deviation of the reference drive, `drivecheck run --deviation X` in file order, in
# reverse order and in one shuffled order must give the same verdict for every vector
# (`drivecheck report diff` lists no change). A verdict that differs is a leak: some vector
# left the drive changed for the ones after it.
#
#   cmake -DDRIVECHECK=<drivecheck> -DDEVIATIONS=<a;b;...> -DOUT=<dir> [-DSEED=<n>]
#         [-DFILTER=<glob>] -P order_independence.cmake
#
# DEVIATIONS may contain "none" (the drive without a deviation). Fails with the differing
# verdicts of every deviation that showed any. The reports stay in OUT only from the first
# deviation that showed a difference on.
foreach(var DRIVECHECK DEVIATIONS OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "order_independence.cmake: -D${var}=... is required")
  endif()
endforeach()
if(NOT DEFINED SEED)
  set(SEED 20261127)
endif()
file(MAKE_DIRECTORY ${OUT})

set(failures "")
foreach(deviation IN LISTS DEVIATIONS)
  set(args run)
  if(NOT deviation STREQUAL "none")
    list(APPEND args --deviation ${deviation})
  endif()
  if(DEFINED FILTER AND NOT FILTER STREQUAL "")
    list(APPEND args --filter ${FILTER})
  endif()
  set(lost FALSE)
  foreach(order IN ITEMS file reverse shuffle:${SEED})
    string(REPLACE ":" "-" tag ${order})
    set(json ${OUT}/${deviation}.${tag}.json)
    file(REMOVE ${json})
    execute_process(COMMAND ${DRIVECHECK} ${args} --order ${order} --json ${json}
                    RESULT_VARIABLE code OUTPUT_QUIET ERROR_VARIABLE run_error)
    # 0 pass, 1 some failure, 3 DUT lost: all leave a report to compare
    if(NOT code MATCHES "^(0|1|3)$" OR NOT EXISTS ${json})
      string(APPEND failures "${deviation} --order ${order}: drivecheck run exit ${code}: ${run_error}\n")
    endif()
    if(code STREQUAL "3")
      set(lost TRUE)
    endif()
  endforeach()
  foreach(tag IN ITEMS reverse shuffle-${SEED})
    execute_process(COMMAND ${DRIVECHECK} report diff ${OUT}/${deviation}.file.json
                            ${OUT}/${deviation}.${tag}.json
                    RESULT_VARIABLE code OUTPUT_VARIABLE diff ERROR_VARIABLE diff_error)
    if(NOT code MATCHES "^(0|1)$")
      string(APPEND failures "${deviation}: report diff file/${tag} failed: ${diff_error}\n")
    elseif(NOT diff MATCHES "0 new failures, 0 fixed, 0 changed, 0 added, 0 removed")
      # A run that lost the DUT (exit 3: it stopped answering, e.g. no boot-up) stops after a
      # number of silent vectors that depends on the order: the vectors one run did not reach
      # ("(absent)") are not compared; every vector both runs reached must agree.
      set(differences "")
      string(REPLACE "\n" ";" lines "${diff}")
      foreach(line IN LISTS lines)
        if(line MATCHES "^(new failure|fixed|changed|added|removed) " AND
           NOT (lost AND line MATCHES "\\(absent\\)"))
          string(APPEND differences "${line}\n")
        endif()
      endforeach()
      if(NOT differences STREQUAL "")
        string(APPEND failures "${deviation}: file order vs ${tag}:\n${differences}")
      endif()
    endif()
  endforeach()
  # The three reports of a deviation are kept only when they disagree (or a run failed): each
  # is 20-50 MB, and keeping all of them filled the disk of a CI machine (about 15 GB for the
  # nine order-deviations tests).
  if(failures STREQUAL "")
    file(REMOVE ${OUT}/${deviation}.file.json ${OUT}/${deviation}.reverse.json
         ${OUT}/${deviation}.shuffle-${SEED}.json)
  endif()
endforeach()

if(NOT failures STREQUAL "")
  message(FATAL_ERROR "verdicts depend on the order:\n${failures}")
endif()
list(LENGTH DEVIATIONS count)
message(STATUS "${count} drive(s): equal verdicts in file, reverse and shuffle:${SEED} order")
