function(ugvr_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wimplicit-fallthrough)
  if(UGVR_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
