# bash completion for raytracer and raytracer-mpi (installed by `make install` as
# share/bash-completion/completions/raytracer; or source this file).
# The options and how many values each takes are read from `raytracer -h` of the
# command being completed, so they are always those of the binary at hand. Files:
# -input offers *.txt (all files when there is none), -cache *.cache (the same), the
# image options offer *.tga, *.ppm and *.png, -merge offers images for every argument;
# folders always.

# Reads `CMD -h` once per command into _raytracer_syn (option -> its value words) and
# _raytracer_accels (the names listed under -accel), _raytracer_formats and
# _raytracer_exts (the formats listed under -format and their extensions, no dot),
# _raytracer_isas (the sets -isa's line names after "used:").
_raytracer_read_help()
{
    local cmd=$1 line syn name after_accel=0 after_format=0 e
    [[ $_raytracer_for == "$cmd" ]] && return 0
    _raytracer_for=$cmd
    declare -gA _raytracer_syn=()
    _raytracer_accels=()
    _raytracer_formats=()
    _raytracer_exts=()
    _raytracer_isas=()
    while IFS= read -r line; do
        if [[ $line == "  -"* ]]; then
            after_accel=0
            after_format=0
            syn=${line#  }
            syn=${syn%%  *}
            if [[ $syn == *", "* ]]; then          # "-h, --help": two names, no values
                for name in ${syn//,/ }; do
                    _raytracer_syn[$name]=
                done
                continue
            fi
            name=${syn%% *}
            # -grid has two lines (nx ny nz, auto): the first one counts
            [[ -n ${_raytracer_syn[$name]+set} ]] && continue
            if [[ $syn == *" "* ]]; then
                _raytracer_syn[$name]=${syn#* }
            else
                _raytracer_syn[$name]=
            fi
            [[ $name == -accel ]] && after_accel=1
            [[ $name == -format ]] && after_format=1
            # "-isa name   widest instruction set used: base, avx2 or avx512"
            if [[ $name == -isa && $line == *"used: "* ]]; then
                e=${line#*used: }
                e=${e//,/ }
                e=${e// or / }
                read -r -a _raytracer_isas <<<"$e"
            fi
        elif ((after_accel)) && [[ $line == "      "[a-z]* ]]; then
            line=${line#"${line%%[! ]*}"}
            _raytracer_accels+=("${line%% *}")
        elif ((after_format)) && [[ $line == "      "[a-z]* ]]; then
            read -r -a syn <<<"$line"
            _raytracer_formats+=("${syn[0]}")
            for e in "${syn[@]:1}"; do
                [[ $e == .* ]] && _raytracer_exts+=("${e#.}")
            done
        elif ((after_format)) && [[ $line == "                           "* ]]; then
            :
        else
            after_accel=0
            after_format=0
        fi
    done < <("$cmd" -h 2>/dev/null)
}

# Files ending in one of the extensions (any case), plus folders.
_raytracer_files()
{
    local cur=$1 ext=$2 f
    local -a files=() dirs=()
    while IFS= read -r f; do
        [[ -n $f ]] && dirs+=("$f")
    done < <(compgen -d -- "$cur")
    while IFS= read -r f; do
        [[ -z $f || -d $f ]] && continue
        if [[ -z $ext ]]; then
            files+=("$f")
        else
            local lower=${f,,}
            local e
            for e in $ext; do
                if [[ $lower == *".$e" ]]; then
                    files+=("$f")
                    break
                fi
            done
        fi
    done < <(compgen -f -- "$cur")
    COMPREPLY=("${files[@]}" "${dirs[@]}")
}

_raytracer()
{
    local cur=${COMP_WORDS[COMP_CWORD]} cmd=${COMP_WORDS[0]}
    local i w pending=0 values=() kind="" merge=0
    COMPREPLY=()
    # Expand a leading ~ of the command so it can be run.
    [[ $cmd == "~"* ]] && cmd=${HOME}${cmd#"~"}
    _raytracer_read_help "$cmd"
    # Walk the words before the cursor: which option's which value is being typed?
    for ((i = 1; i < COMP_CWORD; i++)); do
        w=${COMP_WORDS[i]}
        if ((merge)); then
            continue
        elif ((pending > 0)); then
            ((pending--))
        elif [[ $w == -merge && $i -eq 1 ]]; then
            merge=1
        elif [[ -n ${_raytracer_syn[$w]+set} ]]; then
            read -r -a values <<<"${_raytracer_syn[$w]}"
            pending=${#values[@]}
            # "-grid auto" takes one value
            [[ $w == -grid && ${COMP_WORDS[i + 1]} == auto ]] && pending=1
            kind=$w
        fi
    done
    if ((merge)); then
        compopt -o filenames 2>/dev/null
        _raytracer_files "$cur" "${_raytracer_exts[*]:-tga ppm png}"
        return 0
    fi
    if ((pending > 0)); then
        local word=${values[${#values[@]} - pending]}
        case $kind:$word in
        -input:*)
            compopt -o filenames 2>/dev/null
            _raytracer_files "$cur" "txt"
            # no scene file here: any file
            local n_dirs
            n_dirs=$(compgen -d -- "$cur" | wc -l)
            ((${#COMPREPLY[@]} == n_dirs)) && _raytracer_files "$cur" ""
            ;;
        -cache:*)
            # the set-up cache is no image: *.cache (the name README uses), else any file
            compopt -o filenames 2>/dev/null
            _raytracer_files "$cur" "cache"
            local n_dirs
            n_dirs=$(compgen -d -- "$cur" | wc -l)
            ((${#COMPREPLY[@]} == n_dirs)) && _raytracer_files "$cur" ""
            ;;
        -accel:*)
            COMPREPLY=($(compgen -W "${_raytracer_accels[*]}" -- "$cur"))
            ;;
        -format:*)
            COMPREPLY=($(compgen -W "${_raytracer_formats[*]:-tga ppm png}" -- "$cur"))
            ;;
        -isa:*)
            COMPREPLY=($(compgen -W "${_raytracer_isas[*]}" -- "$cur"))
            ;;
        -grid:nx)
            COMPREPLY=($(compgen -W "auto" -- "$cur"))
            ;;
        *:file | *:out)
            compopt -o filenames 2>/dev/null
            _raytracer_files "$cur" "${_raytracer_exts[*]:-tga ppm png}"
            ;;
        esac
        return 0
    fi
    # An option; -merge only as the first word.
    local -a names=("${!_raytracer_syn[@]}")
    ((COMP_CWORD == 1)) || names=("${names[@]/#-merge/}")
    COMPREPLY=($(compgen -W "${names[*]}" -- "$cur"))
}
complete -F _raytracer raytracer raytracer-mpi ./raytracer ./raytracer-mpi
