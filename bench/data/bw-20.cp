% Blocks world with 20 blocks: a larger instance of the corpus benchmark bw-15 (same laws),
% written for the planner's benchmarks.
:- maxAdditive :: 25.

:- macros
  maxCost -> 24.

:- sorts
  location >> block.

:- objects
  table                     :: location.

:- constants
  loc(block)                :: inertialFluent(location);
  move(block)               :: exogenousAction;
  destination(block)        :: attribute(location) of move(block).

:- variables
  B,B1                      :: block;
  L                         :: location.

% effect of moving a block
move(B) causes loc(B)=L if destination(B)=L.

% a block can be moved only when it is clear
nonexecutable move(B) if loc(B1)=B.

% a block can be moved only to a position that is clear
nonexecutable move(B) 
   if destination(B)=loc(B1) & destination(B)\=table.

% a block can't be moved onto a block that is being moved also
nonexecutable move(B) & move(B1) if destination(B)=B1.

% two blocks can't be on the same block at the same time
constraint loc(B)=loc(B1) ->> loc(B)=table where B @< B1.  

:- sorts
	range.

:- objects
	0..maxAdditive :: range.

:- constants
  cost            :: additiveFluent(range). 

move(B) increments cost by 1.

:- variables
  N                              :: range.

:- objects
  a,b,c,d,e,f,g,h,i,j,k,l,m,n,o,p,q,r,s,t  :: block.

:- show cost=N; move(B); destination(B)=L.

:- query
maxstep :: 0..100;
0:      (cost = 0  &  loc(a) = table
        &  loc(b) = a
        &  loc(c) = b
        &  loc(d) = c
        &  loc(e) = d
        &  loc(f) = table
        &  loc(g) = f
        &  loc(h) = g
        &  loc(i) = h
        &  loc(j) = i
        &  loc(k) = table
        &  loc(l) = k
        &  loc(m) = l
        &  loc(n) = m
        &  loc(o) = n
        &  loc(p) = table
        &  loc(q) = p
        &  loc(r) = q
        &  loc(s) = r
        &  loc(t) = s);
maxstep: ([\/N| cost = N & N=<maxCost]
        &  loc(e) = table
        &  loc(b) = e
        &  loc(j) = b
        &  loc(t) = j
        &  loc(o) = table
        &  loc(i) = o
        &  loc(d) = i
        &  loc(s) = d
        &  loc(n) = table
        &  loc(c) = n
        &  loc(h) = c
        &  loc(r) = h
        &  loc(m) = table
        &  loc(g) = m
        &  loc(q) = g
        &  loc(l) = table
        &  loc(k) = l
        &  loc(f) = k
        &  loc(p) = f
        &  loc(a) = p).
