# Embeds a file into a target at build time (no runtime path lookup), through the
# assembler's .incbin. The symbols are `<name>_data` and `<name>_size` (extern "C").
function(loam_embed_file target name file)
  set(asm ${CMAKE_CURRENT_BINARY_DIR}/embed_${name}.S)
  file(WRITE ${asm}.in
"    .section .rodata
    .global ${name}_data
    .global ${name}_size
    .balign 16
${name}_data:
    .incbin \"@EMBED_FILE@\"
${name}_end:
    .balign 8
${name}_size:
    .quad ${name}_end - ${name}_data
    .section .note.GNU-stack,\"\",@progbits
")
  set(EMBED_FILE ${file})
  configure_file(${asm}.in ${asm} @ONLY)
  set_source_files_properties(${asm} PROPERTIES OBJECT_DEPENDS ${file})
  target_sources(${target} PRIVATE ${asm})
endfunction()
