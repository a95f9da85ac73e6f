# Embeds GLSL shaders into a C file so an installed tool never looks for shader files.
#
# cmake -DSHADER_FILES=<;-list of paths> -DINCLUDE_DIRS=<;-list> -DOUTPUT=<file.c>
#       -P embed_shaders.cmake
#
# For each shader, lines of the form `#include "name"` are replaced by the text of
# `name`, searched in INCLUDE_DIRS in order (recursively; each file is included at most
# once per shader, later includes of it become empty lines). `#include <...>` lines are
# left alone, so a header shared with C can include C-only headers inside `#ifdef`
# blocks that GLSL skips. An unresolved `#include "..."` stops the build.
#
# `#line L F` directives keep every line mapped to (file F, line L), F indexing the
# shader's `files` table (0 = the shader itself): one after each include's text and,
# once a file has included something, one after each #else/#elif/#endif in it, in case
# the include sat in a branch the compiler skipped. GLSL only allows comments before
# `#version`, so the shader's lines up to its `#version` line are copied as they are
# and the first directive comes after it. The output defines vdbs_shader_find()
# (vdbscatter/gpu.h); texts are byte arrays, because string literals beyond 4095
# characters are not portable C.

cmake_minimum_required(VERSION 3.20)

if(NOT DEFINED OUTPUT)
  message(FATAL_ERROR "embed_shaders.cmake: OUTPUT is not set")
endif()

# List operations split on ';' and treat '[', ']' and '\' specially, all of which occur in
# shader code, so these characters stand in for them while a text is a list of lines.
string(ASCII 1 _sub_semicolon)
string(ASCII 2 _sub_lbracket)
string(ASCII 3 _sub_rbracket)
string(ASCII 4 _sub_backslash)

set(_include_regex "^[ \t]*#[ \t]*include[ \t]*\"([^\"]+)\"")
set(_version_regex "^[ \t]*#[ \t]*version[ \t]")
set(_branch_regex "^[ \t]*#[ \t]*(else|elif|endif)([ \t/]|$)")

# Reads a file as text with '\n' line ends and a final newline.
function(_embed_read path out_var)
  file(READ "${path}" content)
  string(REPLACE "\r\n" "\n" content "${content}")
  string(LENGTH "${content}" len)
  if(len GREATER 0)
    math(EXPR last "${len} - 1")
    string(SUBSTRING "${content}" ${last} 1 tail)
    if(NOT tail STREQUAL "\n")
      string(APPEND content "\n")
    endif()
  endif()
  set(${out_var} "${content}" PARENT_SCOPE)
endfunction()

function(_embed_find_include name from_file out_var)
  foreach(dir IN LISTS INCLUDE_DIRS)
    if(dir AND EXISTS "${dir}/${name}" AND NOT IS_DIRECTORY "${dir}/${name}")
      get_filename_component(found "${dir}/${name}" REALPATH)
      set(${out_var} "${found}" PARENT_SCOPE)
      return()
    endif()
  endforeach()
  message(FATAL_ERROR "${from_file}: cannot find included file \"${name}\" in: ${INCLUDE_DIRS}")
endfunction()

# Appends the expansion of `path` (file index `index`) to _embed_text, registering newly
# included files in _embed_paths / _embed_names. `is_main` marks the shader itself.
function(_embed_expand path index is_main)
  _embed_read("${path}" content)

  # Headers without includes (PNanoVDB.h is 125 kB) are copied in one piece.
  string(REGEX MATCH "\n[ \t]*#[ \t]*include[ \t]*\"" has_include "\n${content}")
  if(NOT is_main AND NOT has_include)
    string(APPEND _embed_text "${content}")
    set(_embed_text "${_embed_text}" PARENT_SCOPE)
    return()
  endif()

  foreach(ch IN ITEMS _sub_semicolon _sub_lbracket _sub_rbracket _sub_backslash)
    string(FIND "${content}" "${${ch}}" pos)
    if(NOT pos EQUAL -1)
      message(FATAL_ERROR "${path}: contains ASCII control characters 1-4")
    endif()
  endforeach()
  string(REPLACE ";" "${_sub_semicolon}" content "${content}")
  string(REPLACE "[" "${_sub_lbracket}" content "${content}")
  string(REPLACE "]" "${_sub_rbracket}" content "${content}")
  string(REPLACE "\\" "${_sub_backslash}" content "${content}")
  string(REPLACE "\n" ";" lines "${content}")
  # The final newline leaves one empty element after the last line.
  list(LENGTH lines n)
  if(n GREATER 0)
    list(REMOVE_AT lines -1)
  endif()

  set(line_no 0)
  set(before_version ${is_main})
  set(seen_include FALSE)
  foreach(line IN LISTS lines)
    math(EXPR line_no "${line_no} + 1")
    string(REPLACE "${_sub_semicolon}" ";" line "${line}")
    string(REPLACE "${_sub_lbracket}" "[" line "${line}")
    string(REPLACE "${_sub_rbracket}" "]" line "${line}")
    string(REPLACE "${_sub_backslash}" "\\" line "${line}")

    if(before_version AND line MATCHES "${_version_regex}")
      set(before_version FALSE)
      math(EXPR next "${line_no} + 1")
      string(APPEND _embed_text "${line}\n#line ${next} ${index}\n")
    elseif(line MATCHES "${_include_regex}")
      set(name "${CMAKE_MATCH_1}")
      _embed_find_include("${name}" "${path}:${line_no}" inc_path)
      list(FIND _embed_paths "${inc_path}" inc_index)
      math(EXPR next "${line_no} + 1")
      if(inc_index EQUAL -1)
        list(LENGTH _embed_paths inc_index)
        list(APPEND _embed_paths "${inc_path}")
        get_filename_component(inc_name "${inc_path}" NAME)
        list(APPEND _embed_names "${inc_name}")
        string(APPEND _embed_text "#line 1 ${inc_index}\n")
        _embed_expand("${inc_path}" ${inc_index} FALSE)
        string(APPEND _embed_text "#line ${next} ${index}\n")
        set(seen_include TRUE)
      else()
        # Already included: an empty line keeps the numbering without a directive.
        string(APPEND _embed_text "\n")
      endif()
    elseif(seen_include AND line MATCHES "${_branch_regex}")
      # An include in a branch the compiler skips leaves its directives unapplied:
      # the next branch and the code after #endif restate the numbering.
      math(EXPR next "${line_no} + 1")
      string(APPEND _embed_text "${line}\n#line ${next} ${index}\n")
    else()
      string(APPEND _embed_text "${line}\n")
    endif()
  endforeach()

  set(_embed_text "${_embed_text}" PARENT_SCOPE)
  set(_embed_paths "${_embed_paths}" PARENT_SCOPE)
  set(_embed_names "${_embed_names}" PARENT_SCOPE)
endfunction()

# A C string literal for a file name.
function(_embed_c_string value out_var)
  string(REPLACE "\\" "\\\\" value "${value}")
  string(REPLACE "\"" "\\\"" value "${value}")
  set(${out_var} "\"${value}\"" PARENT_SCOPE)
endfunction()

set(_c "/* Generated by cmake/embed_shaders.cmake from shaders/: do not edit. */\n")
string(APPEND _c "#include <stddef.h>\n#include <string.h>\n\n#include \"vdbscatter/gpu.h\"\n\n")

set(_entries "")
set(_seen_names "")
set(_count 0)
foreach(shader IN LISTS SHADER_FILES)
  if(NOT shader)
    continue()
  endif()
  get_filename_component(shader_path "${shader}" REALPATH)
  get_filename_component(shader_name "${shader}" NAME)
  if(shader_name IN_LIST _seen_names)
    message(FATAL_ERROR "embed_shaders.cmake: two shaders are named ${shader_name}")
  endif()
  list(APPEND _seen_names "${shader_name}")

  set(_embed_text "")
  set(_embed_paths "${shader_path}")
  set(_embed_names "${shader_name}")
  _embed_expand("${shader_path}" 0 TRUE)

  string(HEX "${_embed_text}" hex)
  string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," hex "${hex}")
  # 16 bytes per line: the "0x..," pattern spelled out, as CMake regexes have no {n}.
  string(REPEAT "0x..," 16 row_regex)
  string(REGEX REPLACE "(${row_regex})" "\\1\n" hex "${hex}")
  string(APPEND _c "static const unsigned char text_${_count}[] = {\n${hex}0x00};\n")

  set(names_c "")
  foreach(name IN LISTS _embed_names)
    _embed_c_string("${name}" name_c)
    string(APPEND names_c "    ${name_c},\n")
  endforeach()
  list(LENGTH _embed_names file_count)
  string(APPEND _c "static const char *const files_${_count}[] = {\n${names_c}};\n\n")

  _embed_c_string("${shader_name}" shader_name_c)
  string(APPEND _entries
         "    {${shader_name_c}, (const char *)text_${_count}, files_${_count}, ${file_count}},\n")
  math(EXPR _count "${_count} + 1")
endforeach()

if(_count GREATER 0)
  string(APPEND _c "static const vdbs_shader_source shaders[] = {\n${_entries}};\n\n")
  string(APPEND _c "const vdbs_shader_source *vdbs_shader_find(const char *name)\n{\n")
  string(APPEND _c "    if (!name)\n        return NULL;\n")
  string(APPEND _c "    for (size_t i = 0; i < sizeof shaders / sizeof shaders[0]; i++)\n")
  string(APPEND _c "        if (strcmp(shaders[i].name, name) == 0)\n")
  string(APPEND _c "            return &shaders[i];\n")
  string(APPEND _c "    return NULL;\n}\n")
else()
  string(APPEND _c "const vdbs_shader_source *vdbs_shader_find(const char *name)\n{\n")
  string(APPEND _c "    (void)name;\n    return NULL;\n}\n")
endif()

file(WRITE "${OUTPUT}" "${_c}")
