# The per-ISA kernel objects may define no symbol another object could also define
# (inline functions, template instances, vtables outside their own ISA namespace): the
# linker keeps one copy of such a symbol, and if it kept the AVX2 one, a CPU without AVX2
# would fault in code that was meant to be baseline (STYLE.md section 9).
# Run as: cmake -DNM=nm -DOBJS="a.o;b.o" -P kernel_symbols.cmake
set(_bad "")
set(_seen 0)
foreach(_o ${OBJS})
  if(NOT _o MATCHES "kernel_(sse2|avx2|avx512)\\.cpp\\.o$")
    continue()
  endif()
  math(EXPR _seen "${_seen} + 1")
  execute_process(COMMAND ${NM} -C ${_o} OUTPUT_VARIABLE _syms RESULT_VARIABLE _rc)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "${NM} failed on ${_o}")
  endif()
  string(REPLACE "\n" ";" _lines "${_syms}")
  foreach(_l ${_lines})
    # Weak (W, V) or unique (u) definitions outside accel::bvh::<isa>:: are shareable.
    if(_l MATCHES "^[0-9a-f]+ [WVu] " AND NOT _l MATCHES "accel::bvh::(sse2|avx2|avx512)::"
       AND NOT _l MATCHES "DW.ref.__gxx_personality_v0")
      string(APPEND _bad "\n  ${_o}: ${_l}")
    endif()
  endforeach()
endforeach()
if(NOT _seen EQUAL 3)
  message(FATAL_ERROR "expected the 3 kernel objects, found ${_seen} in: ${OBJS}")
endif()
if(_bad)
  message(FATAL_ERROR "kernel objects define shareable symbols:${_bad}")
endif()
message(STATUS "3 kernel objects, no shareable symbols")
